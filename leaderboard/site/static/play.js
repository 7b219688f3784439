// Playback page: the ground truth and chosen runs side by side on the speaker's rig
// (glTF morph targets), one labelled column per face with a front and a side view,
// driven by the audio element's clock. One WebGL renderer draws every view and each
// view is copied into its column's 2D canvas (so any number of columns works).
import * as THREE from "three";
import { GLTFLoader } from "../vendor/jsm/loaders/GLTFLoader.js";
import { el, fetchJSON, param } from "./site.js";

const FPS = 60;
const VIEW = 400;  // px: each view (front, side) of a column is VIEW x VIEW
const players = document.getElementById("players");
const audio = document.getElementById("audio");
const scrub = document.getElementById("scrub");
const timeLabel = document.getElementById("time");
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
renderer.setSize(VIEW, VIEW, false);

const leaderboard = await fetchJSON("data/leaderboard.json");
const runs = leaderboard.tables.flatMap((t) => [...t.methods, ...t.references]).filter((r) => r.has_tracks);
const runPages = Object.fromEntries(await Promise.all(
  runs.map(async (r) => [r.run, await fetchJSON(`data/runs/${encodeURIComponent(r.run)}.json`)])));

// Sentences: every sentence any run stored.
const sentences = new Map();
for (const page of Object.values(runPages)) {
  for (const s of page.sentences) sentences.set(`${s.subject}/${s.sentence}`, s);
}
const sentenceSelect = document.getElementById("sentence");
for (const key of [...sentences.keys()].sort()) sentenceSelect.append(el("option", { value: key, text: key }));
const wantedSentence = param("subject") && param("sentence") ? `${param("subject")}/${param("sentence")}` : null;
if (wantedSentence && sentences.has(wantedSentence)) sentenceSelect.value = wantedSentence;

const wantedRuns = (param("runs") || "").split(",").filter(Boolean);
const choices = document.getElementById("run-choices");
for (const r of runs) {
  const box = el("input", { type: "checkbox", value: r.run, "data-run": r.run });
  box.checked = wantedRuns.length ? wantedRuns.includes(r.run) : !r.reference && r === runs.find((x) => !x.reference);
  choices.append(el("label", {}, box, ` ${r.label} `));
}
if (param("samples")) document.getElementById("samples").value = param("samples");

const loader = new GLTFLoader();
const rigCache = new Map();
async function rigMesh(subject) {
  if (!rigCache.has(subject)) {
    rigCache.set(subject, loader.loadAsync(`data/rigs/${subject}.glb`).then((gltf) => {
      let mesh = null;
      gltf.scene.traverse((node) => { if (node.isMesh && !mesh) mesh = node; });
      mesh.geometry.computeVertexNormals();
      return mesh;
    }));
  }
  return rigCache.get(subject);
}

let panels = [];
let frames = 1;
let rigNames = [];

// Skin on the front faces; the back faces (the inside of the head, seen through the open
// mouth, the eyes or the neck) a dark unlit red, so the mouth reads as an opaque cavity.
const SKIN = new THREE.MeshStandardMaterial({ color: 0xd9a58c, roughness: 0.8, metalness: 0.0, side: THREE.FrontSide });
const CAVITY = new THREE.MeshBasicMaterial({ color: 0x3b1414, side: THREE.BackSide });

function makePanel(template, title, track) {
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0xf6f6f6);
  const mesh = template.clone();
  mesh.material = SKIN;
  const inside = template.clone();
  inside.material = CAVITY;
  inside.morphTargetInfluences = mesh.morphTargetInfluences;  // one set of weights moves both
  scene.add(mesh, inside);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x444444, 1.6));
  const light = new THREE.DirectionalLight(0xffffff, 1.8);
  light.position.set(0.3, 0.4, 1.0);
  scene.add(light);
  const dictionary = mesh.morphTargetDictionary || {};
  const columns = track.names.map((name) => dictionary[name]);
  const canvas = el("canvas", { class: "head", width: String(VIEW), height: String(2 * VIEW),
    "aria-label": `${title}: front and side view` });
  const figure = el("figure", { class: "head" }, el("figcaption", { text: title }), canvas);
  return { scene, mesh, title, track, columns, figure, context: canvas.getContext("2d") };
}

function cameras(template, aspect) {
  template.geometry.computeBoundingBox();
  const box = template.geometry.boundingBox;
  const center = box.getCenter(new THREE.Vector3());
  const size = box.getSize(new THREE.Vector3());
  // Frame the head: it fills about 85 % of the view's height (the rigs' head spans about half
  // their bounding box's height, whose lower part is the neck and shoulders).
  center.y -= 0.058 * size.y;
  const distance = 0.62 * size.y / (2 * Math.tan((25 / 2) * Math.PI / 180));
  const front = new THREE.PerspectiveCamera(25, aspect, distance / 100, distance * 10);
  front.position.set(center.x, center.y, center.z + distance);
  front.lookAt(center);
  const side = new THREE.PerspectiveCamera(25, aspect, distance / 100, distance * 10);
  side.position.set(center.x + distance, center.y, center.z);
  side.lookAt(center);
  return { front, side };
}

let views = null;

function currentFrame() {
  return Math.max(0, Math.min(frames - 1, Math.floor(audio.currentTime * FPS + 1e-6)));
}

function render(frame = currentFrame()) {
  panels.forEach((panel) => {
    const weights = panel.track.coeffs[Math.min(frame, panel.track.coeffs.length - 1)];
    panel.columns.forEach((target, c) => {
      if (target !== undefined) panel.mesh.morphTargetInfluences[target] = weights[c];
    });
    [views.front, views.side].forEach((camera, row) => {
      renderer.render(panel.scene, camera);
      panel.context.drawImage(renderer.domElement, 0, row * VIEW, VIEW, VIEW);
    });
  });
  timeLabel.textContent = `${audio.currentTime.toFixed(2)} s — frame ${frame} — ${panels.map((p) => p.title).join(" | ")}`;
  if (audio.duration) scrub.value = String(Math.round(1000 * audio.currentTime / audio.duration));
  window.player.frame = frame;
}

async function load() {
  const [subject, sentence] = sentenceSelect.value.split("/");
  const gt = await fetchJSON(`data/sentences/${subject}/${sentence}.json`);
  const template = await rigMesh(subject);
  rigNames = gt.names;
  frames = gt.coeffs.length;
  const samples = Number(document.getElementById("samples").value) || 1;
  const chosen = [...choices.querySelectorAll("input:checked")].map((box) => box.value);
  const newPanels = [makePanel(template, "ground truth", { names: gt.names, coeffs: gt.coeffs })];
  for (const runId of chosen) {
    const entry = runPages[runId].sentences.find((s) => s.subject === subject && s.sentence === sentence);
    if (!entry) continue;
    const label = runs.find((r) => r.run === runId).label;
    for (let k = 0; k < Math.min(samples, entry.samples); k++) {
      let track;
      try {
        track = await fetchJSON(`data/tracks/${encodeURIComponent(runId)}/${subject}/${sentence}-${k}.json`);
      } catch (error) {
        break;  // fewer samples were exported for the site than the run stored
      }
      newPanels.push(makePanel(template, entry.samples > 1 ? `${label} #${k}` : label,
        { names: gt.names, coeffs: track.coeffs }));
    }
  }
  panels = newPanels;
  players.replaceChildren(...panels.map((p) => p.figure));
  views = cameras(template, 1);
  audio.src = `data/audio/${subject}/${sentence}.wav`;
  await new Promise((resolve) => {
    if (audio.readyState >= 1) resolve();
    else audio.addEventListener("loadedmetadata", resolve, { once: true });
  });
  document.getElementById("title").textContent = `Playback: ${subject} / ${sentence}`;
  render(0);
}

function tick() {
  render();
  if (!audio.paused) requestAnimationFrame(tick);
}

window.player = {
  frame: 0,
  // Seek to `seconds` and draw that frame (used by the controls and by tests).
  seek(seconds) {
    return new Promise((resolve) => {
      const done = () => { render(); resolve(window.player.frame); };
      if (Math.abs(audio.currentTime - seconds) < 1e-4) { done(); return; }
      audio.addEventListener("seeked", done, { once: true });
      audio.currentTime = seconds;
    });
  },
  panels: () => panels.map((p) => p.title),
  duration: () => audio.duration,
};

document.getElementById("play").addEventListener("click", async () => {
  if (audio.paused) { await audio.play(); requestAnimationFrame(tick); } else audio.pause();
});
audio.addEventListener("pause", () => { document.getElementById("play").textContent = "play"; });
audio.addEventListener("play", () => { document.getElementById("play").textContent = "pause"; });
scrub.addEventListener("input", () => {
  window.player.seek((Number(scrub.value) / 1000) * (audio.duration || 0));
});
sentenceSelect.addEventListener("change", load);
choices.addEventListener("change", load);
document.getElementById("samples").addEventListener("change", load);

// Say on the page which runs cannot be played back and what playback needs.
const silent = leaderboard.tables.flatMap((t) => [...t.methods, ...t.references]).filter((r) => !r.has_tracks);
if (silent.length) {
  players.before(el("p", { class: "note", id: "playback-needs",
    text: `No 3D playback for ${silent.map((r) => r.label).join(", ")}: playback needs a run's generated tracks ` +
      "next to its result file and the BlendVOCA build it was scored on, on the machine that builds the site " +
      "(python -m leaderboard.site --results DIR --data BUILD --out SITE when the build is not at the path the " +
      "run recorded). The committed leaderboard results hold the scores only: python -m leaderboard.reproduce " +
      "recreates their tracks and build. Each run's page says which of the two is missing." }));
}
if (sentences.size) {
  await load();
} else {
  players.replaceWith(el("p", { class: "note", id: "no-playback",
    text: "No run in this site stored tracks on a dataset available where the site was made (see the method pages)." }));
}
document.body.dataset.ready = "true";
