// robokit's replay of a run record, drawn client-side with three.js (robokit/data/three.min.js: three.js and its
// orbit controls as one script defining THREE, which the page loads first). RK_REPLAY (written by
// robokit/record/replay.py) holds the link paths, the visual shapes, the sample times and each link's world pose per
// sample, and each state machine's stays.
(function () {
  "use strict";
  const D = RK_REPLAY;
  const pane = document.getElementById("rk-pane");
  // The viewer: a renderer in the pane, a scene lit from the sky and from above, a camera with orbit controls.
  // The scene keeps the record's frame (metres, z up); the camera's up is the view's.
  const renderer = new THREE.WebGLRenderer({ antialias: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  pane.appendChild(renderer.domElement);
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0xfafbfc);
  const sky = new THREE.HemisphereLight(0xffffff, 0x8a8a80, 2.2);
  sky.position.set(0, 0, 1);
  scene.add(sky);
  const sun = new THREE.DirectionalLight(0xffffff, 1.6);
  sun.position.set(1.5, -1, 3);
  scene.add(sun);
  const camera = new THREE.PerspectiveCamera(50, 1, 0.01, 200);
  camera.up.set(...(D.view && D.view.up ? D.view.up : [0, 0, 1])); // before the controls: they orbit about it
  camera.position.set(2.5, -2.5, 1.8);
  const controls = new THREE.OrbitControls(camera, renderer.domElement);
  let dirty = true;
  controls.addEventListener("change", () => { dirty = true; });
  const viewer = {
    scene, camera, renderer, controls,
    render() { renderer.render(scene, camera); dirty = false; },
  };
  const fit = () => {
    renderer.setSize(pane.clientWidth, pane.clientHeight);
    camera.aspect = pane.clientWidth / Math.max(1, pane.clientHeight);
    camera.updateProjectionMatrix();
    dirty = true;
  };
  window.addEventListener("resize", fit);
  fit();

  function bytes(b64) {
    const bin = atob(b64);
    const out = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
    return out.buffer;
  }
  const times = new Float32Array(bytes(D.t));
  const poses = new Float32Array(bytes(D.poses));
  const L = D.links.length;
  const root = new THREE.Group();
  root.name = "robokit";
  scene.add(root);
  const groups = D.links.map((path) => {
    const g = new THREE.Group();
    g.name = path;
    root.add(g);
    return g;
  });
  const meshes = D.meshes.map((m) => {
    const g = new THREE.BufferGeometry();
    g.setAttribute("position", new THREE.BufferAttribute(new Float32Array(bytes(m.vertices)), 3));
    g.setIndex(new THREE.BufferAttribute(new Uint32Array(bytes(m.triangles)), 1));
    g.computeVertexNormals();
    return g;
  });

  function geometry(s) {
    if (s.kind === "box") return new THREE.BoxGeometry(s.size[0], s.size[1], s.size[2]);
    if (s.kind === "sphere") return new THREE.SphereGeometry(s.size[0], 24, 16);
    if (s.kind === "cylinder" || s.kind === "capsule") {
      const g = new THREE.CylinderGeometry(s.size[1], s.size[1], s.size[0], 24);
      g.rotateX(Math.PI / 2); // three.js cylinders run along y, PyBullet's along z
      return g;
    }
    if (s.kind === "mesh" && s.mesh !== undefined) return meshes[s.mesh];
    return null;
  }
  for (const s of D.shapes) {
    const g = geometry(s);
    if (g === null) continue;
    const c = s.rgba;
    const material = new THREE.MeshPhongMaterial({
      color: new THREE.Color().setRGB(c[0], c[1], c[2], THREE.SRGBColorSpace), opacity: c[3], transparent: c[3] < 1, side: THREE.DoubleSide,
    });
    const mesh = new THREE.Mesh(g, material);
    if (s.kind === "mesh") mesh.scale.set(s.size[0], s.size[1], s.size[2]);
    g.computeBoundingBox();
    const extent = new THREE.Vector3();
    g.boundingBox.getSize(extent);
    if (Math.max(extent.x * s.size[0], extent.y * s.size[1]) > 5 && c[0] + c[1] + c[2] > 2.9) {
      material.color.setRGB(0.72, 0.76, 0.8, THREE.SRGBColorSpace); // a white ground plane (its texture is not drawn): grey, under white robots
    }
    mesh.position.set(s.position[0], s.position[1], s.position[2]);
    mesh.quaternion.set(s.quaternion[0], s.quaternion[1], s.quaternion[2], s.quaternion[3]);
    mesh.name = D.links[s.frame];
    groups[s.frame].add(mesh);
  }

  const slider = document.getElementById("rk-time");
  const clock = document.getElementById("rk-clock");
  const button = document.getElementById("rk-play");
  const speedSel = document.getElementById("rk-speed");
  let now = 0, playing = false, last = null;

  function sampleAt(time) {
    let lo = 0, hi = times.length - 1;
    while (lo < hi) {
      const mid = (lo + hi + 1) >> 1;
      if (times[mid] <= time + 1e-6) lo = mid; else hi = mid - 1;
    }
    return lo;
  }
  function statesAt(time) {
    return D.machines.map((m) => {
      let state = m.spans.length ? m.spans[0][0] : "";
      for (const s of m.spans) if (s[1] <= time) state = s[0];
      return m.name + ": " + state;
    });
  }
  function show(time) {
    now = Math.min(Math.max(time, 0), D.duration);
    const i = sampleAt(now);
    for (let k = 0; k < L; k++) {
      const o = (i * L + k) * 7;
      const g = groups[k];
      if (Number.isNaN(poses[o])) { g.visible = false; continue; }
      g.visible = true;
      g.position.set(poses[o], poses[o + 1], poses[o + 2]);
      g.quaternion.set(poses[o + 3], poses[o + 4], poses[o + 5], poses[o + 6]);
    }
    slider.value = String(Math.round((now / (D.duration || 1)) * 1000));
    clock.textContent = "t = " + now.toFixed(2) + " s  \u00b7  " + statesAt(now).join("  \u00b7  ");
    seen(now);
    for (const cursor of document.querySelectorAll(".rk-cursor")) {
      cursor.style.left = (100 * now / (D.duration || 1)) + "%";
    }
    dirty = true;
  }
  // The first view is the video's: D.view is the camera `robokit video` looks through by default (its "iso" view of
  // this scene: behind the robot and to its left, 30 degrees above the middle of the scene's box, with the same
  // vertical field of view), so the replay opens on the picture the video shows; a wider pane shows more at the sides.
  // The orbit controls turn about the view's target.
  function frame() {
    show(0);
    const v = D.view;
    if (!v) return;
    camera.position.set(...v.eye);
    camera.fov = v.fov;
    camera.updateProjectionMatrix();
    controls.target.set(...v.target);
    controls.update();
    dirty = true;
  }

  // What the robot's camera saw (frames saved with --save-frames): the latest one at or before the time shown.
  const seenBox = document.getElementById("rk-seen");
  function seen(time) {
    let latest = null;
    for (const f of D.frames) if (f.t <= time + 1e-6) latest = f;
    seenBox.style.display = latest ? "block" : "none";
    if (latest && seenBox.dataset.src !== latest.png) {
      seenBox.dataset.src = latest.png;
      let img = seenBox.querySelector("img");
      if (!img) { // made only when there is a frame to show: a page without frames has no empty image
        img = document.createElement("img");
        img.alt = "camera frame";
        seenBox.prepend(img);
      }
      img.src = latest.png;
      seenBox.querySelector("figcaption").textContent = latest.camera + " at t = " + latest.t.toFixed(2) + " s";
    }
  }

  // A body's name (and link) under the pointer.
  const hover = document.getElementById("rk-hover");
  const ray = new THREE.Raycaster();
  viewer.renderer.domElement.addEventListener("pointermove", (event) => {
    const rect = viewer.renderer.domElement.getBoundingClientRect();
    const at = new THREE.Vector2(((event.clientX - rect.left) / rect.width) * 2 - 1,
      -((event.clientY - rect.top) / rect.height) * 2 + 1);
    ray.setFromCamera(at, viewer.camera);
    const hit = ray.intersectObjects(root.children, true).find((h) => h.object.visible && h.object.name);
    hover.style.display = hit ? "block" : "none";
    if (hit) hover.textContent = hit.object.name;
  });

  const bars = document.getElementById("rk-states");
  const palette = ["#8ecae6", "#ffb703", "#90be6d", "#f4a261", "#cdb4db", "#e9c46a", "#a8dadc", "#f28482"];
  for (const m of D.machines) {
    const row = document.createElement("div");
    row.className = "rk-row";
    const label = document.createElement("span");
    label.className = "rk-name";
    label.textContent = m.name;
    const track = document.createElement("div");
    track.className = "rk-track";
    const names = [...new Set(m.spans.map((s) => s[0]))];
    for (const s of m.spans) {
      const seg = document.createElement("div");
      seg.className = "rk-span";
      seg.style.left = (100 * s[1] / (D.duration || 1)) + "%";
      seg.style.width = Math.max(0.3, 100 * (s[2] - s[1]) / (D.duration || 1)) + "%";
      seg.style.background = palette[names.indexOf(s[0]) % palette.length];
      seg.title = s[0] + "  " + s[1].toFixed(2) + "\u2013" + s[2].toFixed(2) + " s";
      seg.dataset.start = String(s[1]);
      seg.textContent = s[0];
      seg.addEventListener("click", () => { playing = false; button.textContent = "play"; show(s[1]); });
      track.appendChild(seg);
    }
    const cursor = document.createElement("div");
    cursor.className = "rk-cursor";
    track.appendChild(cursor);
    row.appendChild(label);
    row.appendChild(track);
    bars.appendChild(row);
  }

  button.addEventListener("click", () => {
    if (!playing && now >= D.duration) show(0);
    playing = !playing;
    button.textContent = playing ? "pause" : "play";
  });
  speedSel.addEventListener("change", () => { last = null; });
  slider.addEventListener("input", () => { show((Number(slider.value) / 1000) * D.duration); });
  function tick(ts) {
    const canvas = renderer.domElement;
    if (canvas.clientWidth !== pane.clientWidth || canvas.clientHeight !== pane.clientHeight) fit();
    if (playing && last !== null) {
      show(now + ((ts - last) / 1000) * Number(speedSel.value));
      if (now >= D.duration) { playing = false; button.textContent = "play"; }
    }
    last = ts;
    if (dirty) viewer.render();
    requestAnimationFrame(tick);
  }
  frame();
  fit();
  requestAnimationFrame(tick);

  // For tests and curious students: where a world point (metres) appears on the canvas, in CSS pixels.
  window.rkReplay = {
    show, duration: D.duration, viewer,
    time: () => now,
    project(x, y, z) {
      viewer.render();
      root.updateMatrixWorld(true);
      const v = root.localToWorld(new THREE.Vector3(x, y, z)).project(viewer.camera);
      const rect = viewer.renderer.domElement.getBoundingClientRect();
      return [rect.left + (v.x + 1) / 2 * rect.width, rect.top + (1 - v.y) / 2 * rect.height];
    },
  };
})();
