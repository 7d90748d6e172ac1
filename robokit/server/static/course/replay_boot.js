// The run page's 3D replay: fetch the run's replay.json (same origin), hand it to robokit's replay script as
// RK_REPLAY, then load that script (the viewer, three.js, is loaded before this file, both deferred, in order).
(function () {
  "use strict";
  const box = document.getElementById("rk-replay");
  if (!box) return;
  const say = (text) => {
    const note = document.createElement("p");
    note.className = "muted";
    note.textContent = text;
    box.replaceWith(note);
  };
  fetch(box.dataset.src, { credentials: "same-origin" })
    .then((answer) => {
      if (!answer.ok) throw new Error("HTTP " + answer.status);
      return answer.json();
    })
    .then((data) => {
      window.RK_REPLAY = data;
      const script = document.createElement("script");
      script.src = box.dataset.script;
      script.onerror = () => say("The replay's script could not be loaded.");
      document.body.appendChild(script);
    })
    .catch((err) => say("The replay could not be loaded (" + err.message + ")."));
})();
