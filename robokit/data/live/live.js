// robokit's live view: the replay viewer (replay.js, drawing RK_REPLAY, the scene as the run started) moved by the
// frames the run publishes (Server-Sent Events from /events), the state machines with the active state highlighted,
// the latest transitions, the clock and the outcome; pause, step and speed buttons, and keys sent to the robot; the
// sensors picked in the page: lidar scans drawn in the scene, camera images (JPEG from /camera/NAME, at most a few a
// second), other readings plotted against sim time.
(function () {
  "use strict";
  const token = new URLSearchParams(window.location.search).get("token");
  const url = (path, query) => {
    const q = new URLSearchParams(query || {});
    if (token) q.set("token", token);
    const text = q.toString();
    return path + (text ? "?" + text : "");
  };
  const viewer = window.rkReplay.viewer;
  const root = viewer.scene.getObjectByName("robokit");
  const groups = RK_REPLAY.links.map((path) => root.children.find((g) => g.name === path));
  const clock = document.getElementById("live-clock");
  const outcome = document.getElementById("live-outcome");
  const pauseButton = document.getElementById("live-pause");
  const speed = document.getElementById("live-speed");
  const recent = document.getElementById("live-recent");
  let latest = null;
  let shownSeq = 0;

  // Each machine: its name and every state, the active one highlighted.
  const machinesBox = document.getElementById("live-machines");
  const stateCells = {};
  for (const m of RK_LIVE.machines) {
    const row = document.createElement("div");
    row.className = "live-machine";
    row.dataset.machine = m.name;
    const label = document.createElement("b");
    label.textContent = m.name;
    row.appendChild(label);
    stateCells[m.name] = {};
    for (const s of m.states) {
      const cell = document.createElement("span");
      cell.className = "live-state";
      cell.dataset.state = s;
      cell.textContent = s;
      row.appendChild(cell);
      stateCells[m.name][s] = cell;
    }
    machinesBox.appendChild(row);
  }

  function draw(f) {
    const p = f.poses;
    for (let k = 0; k < groups.length; k++) {
      const g = groups[k];
      if (!g) continue;
      const o = k * 7;
      if (p[o] === null) { g.visible = false; continue; }
      g.visible = true;
      g.position.set(p[o], p[o + 1], p[o + 2]);
      g.quaternion.set(p[o + 3], p[o + 4], p[o + 5], p[o + 6]);
    }
    clock.textContent = "t = " + f.t.toFixed(3) + " s" + (f.paused ? "  (paused)" : "");
    pauseButton.querySelector(".en").textContent = f.paused ? "resume" : "pause";
    pauseButton.querySelector(".ko").textContent = f.paused ? "계속" : "일시정지";
    speed.value = String(f.speed);
    for (const [machine, cells] of Object.entries(stateCells)) {
      for (const [state, cell] of Object.entries(cells)) cell.classList.toggle("active", f.states[machine] === state);
    }
    recent.replaceChildren(...f.recent.slice().reverse().map((r) => {
      const li = document.createElement("li");
      li.textContent = r.t.toFixed(2) + " s  " + (r.kind === "transition"
        ? r.machine + ": " + r.source_state + " \u2192 " + r.dest_state + " (" + r.trigger + ")"
        : r.source + " " + r.kind + (r.child ? " " + r.child : "") + (r.body ? " " + r.body : ""));
      return li;
    }));
    if (f.outcome) {
      outcome.textContent = f.outcome.outcome + ": " + f.outcome.reason;
      outcome.className = f.outcome.outcome;
      // The run's page is made from its record once the run has ended.
      if (RK_LIVE.run.folder) document.getElementById("live-after").textContent =
        "The run's page · 실행 페이지: robokit view " + RK_LIVE.run.id + "   (record: " + RK_LIVE.run.folder + ")";
    }
    if (f.sensors) for (const [name, s] of Object.entries(f.sensors)) if (views[name]) views[name].update(s, f);
    viewer.render();
  }
  // Frames are drawn at the page's own rate: only the latest one counts, the rest are dropped.
  function paint() {
    if (latest !== null && latest.seq !== shownSeq) {
      shownSeq = latest.seq;
      draw(latest);
    }
    requestAnimationFrame(paint);
  }
  let events = null;
  function connect() {
    if (events) events.close();
    const names = [...picked].join(",");
    events = new EventSource(url("/events", names ? { sensors: names } : {}));
    events.onmessage = (e) => { latest = JSON.parse(e.data); };
  }

  // ----------------------------------------------------------------- sensors
  const picked = new Set(RK_LIVE.picked || []);
  const views = {};
  const viewsBox = document.getElementById("live-views");
  const KIND = { scan: "lidar", image: "camera", values: "plot" };
  const NOT_YET = "no reading yet (the run makes one when something reads the sensor) · 아직 측정값 없음";

  function panel(name, kind) {
    const box = document.createElement("div");
    box.className = "live-sensor";
    box.dataset.sensor = name;
    const title = document.createElement("h4");
    title.textContent = name + " (" + KIND[kind] + ")";
    const note = document.createElement("div");
    note.className = "none";
    note.textContent = NOT_YET;
    box.append(title, note);
    viewsBox.appendChild(box);
    return { box, title, note };
  }

  // A lidar: its rays (red to a hit, faint green where nothing was hit) and its hit points, in the 3D scene.
  function scanView(name) {
    const p = panel(name, "scan");
    const rays = new THREE.LineSegments(new THREE.BufferGeometry(),
      new THREE.LineBasicMaterial({ vertexColors: true, transparent: true, opacity: 0.6 }));
    const hits = new THREE.Points(new THREE.BufferGeometry(), new THREE.PointsMaterial({ color: 0xd00000, size: 4,
      sizeAttenuation: false }));
    rays.name = "live-scan-rays:" + name;
    hits.name = "live-scan-hits:" + name;
    root.add(rays, hits);
    let tick = null;
    return {
      tick: () => tick,
      hits: () => Array.from(hits.geometry.getAttribute("position") ? hits.geometry.getAttribute("position").array : []),
      update(s) {
        if (s.tick === tick) return;
        tick = s.tick;
        if (s.tick < 0) return;
        const n = s.hit.length, line = [], colour = [], points = [];
        const o = s.origin;
        for (let i = 0; i < n; i++) {
          const x = s.points[3 * i], y = s.points[3 * i + 1], z = s.points[3 * i + 2];
          const hit = s.hit[i] === "1";
          line.push(o[0], o[1], o[2], x, y, z);
          const c = hit ? [0.85, 0.1, 0.1] : [0.2, 0.7, 0.3];
          colour.push(...c, ...c);
          if (hit) points.push(x, y, z);
        }
        rays.geometry.setAttribute("position", new THREE.Float32BufferAttribute(line, 3));
        rays.geometry.setAttribute("color", new THREE.Float32BufferAttribute(colour, 3));
        hits.geometry.setAttribute("position", new THREE.Float32BufferAttribute(points, 3));
        rays.geometry.computeBoundingSphere();
        hits.geometry.computeBoundingSphere();
        p.note.textContent = (points.length / 3) + " of " + n + " rays hit · t = " +
          (s.tick * RK_LIVE.time_step).toFixed(3) + " s";
      },
      remove() { root.remove(rays, hits); p.box.remove(); },
    };
  }

  // A camera: its latest image, fetched when the frame names a newer one, one request at a time, at most
  // IMAGE_HZ a second.
  const IMAGE_HZ = 5;
  function imageView(name) {
    const p = panel(name, "image");
    const img = document.createElement("img");
    img.alt = name;
    p.box.insertBefore(img, p.note);
    let wanted = -1, shown = -1, busy = false, last = 0;
    function load() {
      if (busy || wanted === shown || performance.now() - last < 1000 / IMAGE_HZ) return;
      busy = true;
      last = performance.now();
      fetch(url("/camera/" + encodeURIComponent(name))).then((r) => {
        if (!r.ok) throw new Error(r.status);
        const tick = Number(r.headers.get("X-Robokit-Tick"));
        return r.blob().then((b) => {
          if (img.src) URL.revokeObjectURL(img.src);
          img.src = URL.createObjectURL(b);
          shown = tick;
          p.note.textContent = "t = " + (tick * RK_LIVE.time_step).toFixed(3) + " s";
        });
      }).catch(() => {}).finally(() => { busy = false; });
    }
    const timer = setInterval(load, 1000 / IMAGE_HZ);
    return {
      tick: () => shown,
      update(s) {
        if (s.tick < 0) return;
        if (img.width === 0) { img.width = Math.max(160, s.width); }
        wanted = s.tick;
        load();
      },
      remove() { clearInterval(timer); p.box.remove(); },
    };
  }

  // Other readings: every number of the reading (a field, a short array's items, a list's length) plotted
  // against sim time over the last PLOT_SECONDS.
  const PLOT_SECONDS = 10;
  const COLOURS = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf"];
  function plotView(name) {
    const p = panel(name, "values");
    const canvas = document.createElement("canvas");
    canvas.width = 420;
    canvas.height = 140;
    const legend = document.createElement("div");
    legend.className = "legend";
    p.box.insertBefore(canvas, p.note);
    p.box.insertBefore(legend, p.note);
    const series = {}; // field -> [[tick, value], ...]
    const hidden = new Set(); // fields the student clicked off in the legend
    const keys = {}; // field -> its legend entry
    let tick = null;
    function legendEntry(f, colour) {
      const span = document.createElement("span");
      span.style.color = colour;
      span.style.cursor = "pointer";
      span.title = "click to hide or show · 눌러서 숨기기/보이기";
      span.dataset.field = f;
      span.addEventListener("click", () => {
        if (hidden.has(f)) hidden.delete(f); else hidden.add(f);
        span.style.opacity = hidden.has(f) ? "0.4" : "1";
        span.style.textDecoration = hidden.has(f) ? "line-through" : "none";
        drawPlot();
      });
      legend.appendChild(span);
      return span;
    }
    function drawPlot() {
      const ctx = canvas.getContext("2d");
      ctx.clearRect(0, 0, canvas.width, canvas.height);
      const all = Object.keys(series);
      all.forEach((f, i) => {
        const key = keys[f] || (keys[f] = legendEntry(f, COLOURS[i % COLOURS.length]));
        const last = series[f][series[f].length - 1];
        key.textContent = f + " = " + (last ? Number(last[1].toPrecision(6)) : "");
      });
      const fields = all.filter((f) => !hidden.has(f));
      let lo = Infinity, hi = -Infinity, k0 = Infinity, k1 = -Infinity;
      for (const f of fields) {
        for (const [k, v] of series[f]) { lo = Math.min(lo, v); hi = Math.max(hi, v); k0 = Math.min(k0, k); k1 = Math.max(k1, k); }
      }
      if (!fields.length || !isFinite(lo)) return;
      if (hi - lo < 1e-9) { hi += 0.5; lo -= 0.5; }
      const dt = RK_LIVE.time_step, span = Math.max((k1 - k0) * dt, 1e-6); // up to PLOT_SECONDS, kept as they come
      const X = (k) => 34 + (canvas.width - 38) * (k - k0) * dt / span;
      const Y = (v) => 6 + (canvas.height - 18) * (hi - v) / (hi - lo);
      ctx.fillStyle = "#888";
      ctx.font = "10px sans-serif";
      ctx.fillText(hi.toPrecision(3), 0, 12);
      ctx.fillText(lo.toPrecision(3), 0, canvas.height - 10);
      fields.forEach((f) => {
        ctx.strokeStyle = keys[f].style.color;
        ctx.beginPath();
        series[f].forEach(([k, v], j) => (j ? ctx.lineTo(X(k), Y(v)) : ctx.moveTo(X(k), Y(v))));
        ctx.stroke();
      });
    }
    return {
      tick: () => tick,
      series: () => series,
      shown: () => Object.keys(series).filter((f) => !hidden.has(f)),
      update(s) {
        if (s.tick === tick || s.tick < 0) return;
        tick = s.tick;
        const keep = s.tick - PLOT_SECONDS / RK_LIVE.time_step;
        for (const [f, v] of Object.entries(s.values)) {
          const line = series[f] || (series[f] = []);
          line.push([s.tick, v]);
          while (line.length && line[0][0] < keep) line.shift();
        }
        p.note.textContent = "t = " + (s.tick * RK_LIVE.time_step).toFixed(3) + " s";
        drawPlot();
      },
      remove() { p.box.remove(); },
    };
  }

  const MAKERS = { scan: scanView, image: imageView, values: plotView };
  function show(name, kind, on) {
    if (on && !views[name]) views[name] = MAKERS[kind](name);
    if (!on && views[name]) { views[name].remove(); delete views[name]; }
  }
  const picks = document.getElementById("live-picks");
  for (const s of RK_LIVE.sensors || []) {
    const label = document.createElement("label");
    const box = document.createElement("input");
    box.type = "checkbox";
    box.value = s.name;
    box.checked = picked.has(s.name);
    box.addEventListener("change", () => {
      if (box.checked) picked.add(s.name); else picked.delete(s.name);
      show(s.name, s.kind, box.checked);
      connect();
    });
    const kind = document.createElement("span");
    kind.className = "kind";
    kind.textContent = " " + (s.component === "actuator" ? "actuator" : KIND[s.kind]);
    label.append(box, " " + s.name, kind);
    picks.appendChild(label);
    show(s.name, s.kind, box.checked);
  }
  if (!(RK_LIVE.sensors || []).length) picks.textContent = "This run has no sensors. · 센서가 없습니다.";

  connect();
  requestAnimationFrame(paint);

  function post(path, body) {
    return fetch(url(path), { method: "POST", headers: { "Content-Type": "application/json" },
      body: JSON.stringify(body) });
  }
  pauseButton.addEventListener("click", () => {
    post("/control", { action: latest && latest.paused ? "resume" : "pause" });
  });
  document.getElementById("live-step").addEventListener("click", () => post("/control", { action: "step" }));
  speed.addEventListener("change", () => post("/control", { action: "speed", value: speed.value }));

  // Keys, named as the keyboard sensor names them.
  const NAMES = { ArrowUp: "up", ArrowDown: "down", ArrowLeft: "left", ArrowRight: "right", Enter: "return", " ": "space" };
  function keyName(e) {
    if (NAMES[e.key]) return NAMES[e.key];
    const k = e.key.length === 1 ? e.key.toLowerCase() : "";
    return /^[a-z0-9]$/.test(k) ? k : null;
  }
  const held = new Set();
  function onKey(e, down) {
    if (e.target && (e.target.tagName === "SELECT" || e.target.tagName === "INPUT")) return;
    const name = keyName(e);
    if (name === null) return;
    e.preventDefault();
    if (down === held.has(name)) return; // the browser's auto-repeat: the key is held already
    if (down) held.add(name); else held.delete(name);
    post("/key", { key: name, down });
  }
  window.addEventListener("keydown", (e) => onKey(e, true));
  window.addEventListener("keyup", (e) => onKey(e, false));
  window.addEventListener("blur", () => { for (const name of held) post("/key", { key: name, down: false }); held.clear(); });

  window.rkLive = { latest: () => latest, shown: () => shownSeq, groups, post, views };
})();
