// robokit's live view: the replay viewer (replay.js, drawing RK_REPLAY, the scene as the run started) moved by the
// frames the run publishes (Server-Sent Events from /events), the state machines with the active state highlighted,
// the latest transitions, the clock and the outcome; pause, step and speed buttons, and keys sent to the robot.
(function () {
  "use strict";
  const token = new URLSearchParams(window.location.search).get("token");
  const url = (path) => path + (token ? "?token=" + encodeURIComponent(token) : "");
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
    pauseButton.textContent = f.paused ? "resume" : "pause";
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
        "The run's page: robokit view " + RK_LIVE.run.id + "   (record: " + RK_LIVE.run.folder + ")";
    }
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
  const events = new EventSource(url("/events"));
  events.onmessage = (e) => { latest = JSON.parse(e.data); };
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

  window.rkLive = { latest: () => latest, shown: () => shownSeq, groups, post };
})();
