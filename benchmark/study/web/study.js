// The study's pages: one jsPsych trial per page (instructions, sound check, or one question),
// built from the page's JSON block (#study-data). The answer is POSTed to the server, which
// writes it before replying; then the page reloads and the server sends the next step.
(function () {
  "use strict";
  const data = JSON.parse(document.getElementById("study-data").textContent);
  const base = location.pathname.endsWith("/") ? location.pathname : location.pathname + "/";
  const esc = (s) => String(s).replace(/[&<>"']/g, (c) => ({"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;"}[c]));
  const label = (choice) => ({left: "Left", right: "Right"}[choice] || choice);

  function progress() {
    const el = document.getElementById("progress");
    const p = data.progress;
    if (data.step === "question" && data.screen.practice) el.textContent = "Practice question (not counted)";
    else if (data.step === "question") el.textContent = "Question " + (p.done + 1) + " of " + p.total;
    else el.textContent = p.total + " questions";
    const bar = document.createElement("div");
    bar.className = "bar";
    bar.style.width = (p.total ? (100 * p.done / p.total) : 0) + "%";
    el.appendChild(bar);
  }

  function ready(step) {
    document.body.dataset.step = step;
    document.body.dataset.ready = "true";
  }

  function send(path, body) {
    const display = document.getElementById("jspsych-target");
    display.innerHTML = '<p id="saving">Saving\u2026</p>';
    return fetch(base + "api/" + path, {
      method: "POST", headers: {"Content-Type": "application/json"}, body: JSON.stringify(body || {}),
      credentials: "same-origin",
    }).then((r) => r.json().catch(() => ({})).then((json) => ({status: r.status, ok: r.ok, body: json})))
      .then((r) => {
        if (r.ok || r.status === 409) { location.replace(base); return; }
        display.innerHTML = '<p id="error">' + esc(r.body.error || ("error " + r.status)) + "</p>";
      }, () => {
        display.innerHTML = '<p id="error">Could not reach the server. </p>';
        const retry = document.createElement("button");
        retry.className = "jspsych-btn"; retry.id = "retry"; retry.textContent = "Try again";
        retry.onclick = () => send(path, body);
        display.appendChild(retry);
      });
  }

  // Clips side by side, played one after the other by the Play button (each with its own sound);
  // `done` runs once the last one has played to its end.
  function clipsHtml(media, captions) {
    const figures = media.map((src, i) =>
      '<figure><video id="clip-' + i + '" src="' + esc(src) + '" preload="auto" playsinline></video>' +
      (captions ? "<figcaption>" + esc(captions[i]) + "</figcaption>" : "") + "</figure>").join("");
    return '<div class="clips clips-' + media.length + '">' + figures + "</div>" +
      '<p><button type="button" class="jspsych-btn play" id="play">Play</button> ' +
      '<span id="watch-note" class="note">' + (media.length > 1 ? "The clips play one after the other. " : "") +
      "Watch to the end to answer.</span></p>";
  }

  function wireClips(count, done) {
    const videos = Array.from({length: count}, (_, i) => document.getElementById("clip-" + i));
    const play = document.getElementById("play");
    let finished = false;
    function playFrom(i) {
      videos.forEach((v, k) => v.classList.toggle("playing", k === i));
      if (i >= videos.length) {
        play.disabled = false; play.textContent = "Play again";
        if (!finished) { finished = true; document.body.dataset.watched = "true"; done(); }
        return;
      }
      const v = videos[i];
      v.currentTime = 0;
      v.onended = () => playFrom(i + 1);
      const started = v.play();
      if (started && started.catch) started.catch(() => { play.disabled = false; play.textContent = "Play"; });
    }
    play.addEventListener("click", () => { play.disabled = true; playFrom(0); });
  }

  const jsPsych = initJsPsych({display_element: "jspsych-target"});
  let trial;
  if (data.step === "instructions") {
    trial = {
      type: jsPsychHtmlButtonResponse,
      stimulus: "<h1>Instructions</h1>" +
        "<p>You will watch short videos of an animated talking face, with sound, and answer one question per screen.</p>" +
        "<p>Comparisons show two faces side by side (left and right) that play one after the other; " +
        "ratings show one face scored from 1 to 5. Each video must play to its end before you can answer; " +
        "you may play it again.</p>" +
        "<p>First a sound check (type the word you hear), then one practice question, then " + esc(data.progress.total) +
        " questions. Some questions check your attention; their answer is obvious. Please answer carefully: " +
        "there are no right or wrong answers otherwise.</p>",
      choices: ["Continue"],
      button_html: (c) => '<button class="jspsych-btn" id="continue">' + esc(c) + "</button>",
      on_load: () => ready("instructions"),
      on_finish: () => send("instructions"),
    };
  } else if (data.step === "sound_check") {
    const sc = data.sound_check;
    trial = {
      type: jsPsychSurveyText,
      preamble: '<h1>Sound check</h1><p id="sound-prompt">' + esc(sc.prompt) + "</p>" +
        (sc.failed_before ? '<p class="warning" id="sound-retry">That was not the answer. Please play the clip again (' +
          esc(sc.attempts_left) + " tries left).</p>" : "") + clipsHtml([sc.media], null),
      questions: [{prompt: "Your answer:", name: "word", required: true}],
      button_label: "Continue",
      on_load: () => { wireClips(1, () => {}); ready("sound_check"); },
      on_finish: (d) => send("sound-check", {word: String(d.response.word || "")}),
    };
  } else if (data.step === "question") {
    const s = data.screen;
    const captions = s.media.length > 1 ? ["Left", "Right"] : null;
    trial = {
      type: jsPsychHtmlButtonResponse,
      stimulus: (s.practice ? '<p class="note">Practice: this answer is not counted.</p>' : "") +
        clipsHtml(s.media, captions) + '<p class="prompt" id="prompt">' + esc(s.prompt) + "</p>",
      choices: s.choices,
      button_html: (c) => '<button class="jspsych-btn answer" data-value="' + esc(c) + '">' + esc(label(c)) + "</button>",
      on_load: () => {
        const buttons = Array.from(document.querySelectorAll("button.answer"));
        const enable = () => buttons.forEach((b) => b.removeAttribute("disabled"));
        if (s.first_of_trial) buttons.forEach((b) => b.setAttribute("disabled", "disabled"));
        else document.body.dataset.watched = "true";
        wireClips(s.media.length, enable);
        ready("question");
      },
      on_finish: (d) => send("answer", {trial: s.trial, question: s.question, choice: s.choices[d.response],
                                         rt_ms: Math.max(0, Math.round(d.rt))}),
    };
  }
  progress();
  jsPsych.run([trial]);
})();
