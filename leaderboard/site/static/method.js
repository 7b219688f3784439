// Method page: per-sentence scores, tracks against the ground truth, lip motion
// against the speech envelope, and the run's provenance.
import { arrow, el, fetchJSON, fmt, linePlot, makeSortable, param, sortBodies } from "./site.js";

const runId = param("run");
const run = await fetchJSON(`data/runs/${encodeURIComponent(runId)}.json`);
document.title = `${run.label} — BlendVOCA`;
document.getElementById("title").textContent = `${run.label} (${run.method.output || "coefficients"} output)` +
  (run.convergence && run.convergence.settled === false ? " \u2020 not settled" : "");

// Per-sentence table.
const metricNames = run.metric_order.filter((name) =>
  run.per_sentence.some((row) => row.metrics[name] !== undefined && row.metrics[name] !== null));
const header = el("tr", {}, el("th", { class: "sortable label", "data-column": "0", text: "subject" }),
  el("th", { class: "sortable label", "data-column": "1", text: "sentence" }));
metricNames.forEach((name, i) => {
  const spec = run.metrics[name];
  header.append(el("th", { class: "sortable", "data-column": String(i + 2), "data-metric": name,
    text: `${spec.label} ${arrow(spec.higher_is_better)}` }));
});
const body = el("tbody");
for (const row of run.per_sentence) {
  const tr = el("tr", {}, el("td", { class: "label", "data-value": row.subject, text: row.subject }),
    el("td", { class: "label", "data-value": row.sentence, text: row.sentence }));
  for (const name of metricNames) {
    const v = row.metrics[name];
    tr.append(el("td", { "data-value": v === null || v === undefined ? "" : String(v), text: fmt(v) }));
  }
  body.append(tr);
}
const table = el("table", { id: "per-sentence-table" }, el("thead", {}, header), body);
makeSortable(table);
document.getElementById("per-sentence").append(
  run.per_sentence.length ? table : el("p", { class: "note", text: "This run stored no per-sentence scores." }));

const worstMetric = document.getElementById("worst-metric");
metricNames.filter((n) => run.metrics[n].higher_is_better !== null).forEach((name) =>
  worstMetric.append(el("option", { value: name, text: run.metrics[name].label })));
document.getElementById("worst-first").addEventListener("click", () => {
  const name = worstMetric.value;
  const column = metricNames.indexOf(name) + 2;
  sortBodies(table, column, run.metrics[name].higher_is_better === false);
});

// Provenance.
const provenance = document.getElementById("provenance");
const facts = {
  method: run.method.name, config: JSON.stringify(run.method.config, null, 1),
  dataset: `${run.dataset.manifest_hash} (${run.dataset.split}, ${run.dataset.num_sentences} sentences)`,
  protocol: JSON.stringify(run.protocol, null, 1),
  ...Object.fromEntries(Object.entries(run.provenance).map(([k, v]) => [k, JSON.stringify(v, null, 1)])),
};
if (run.seeds && run.seeds.length) {
  facts.seeds = run.seeds.join(", ");
  for (const entry of run.per_seed || []) facts[`seed ${entry.seed}`] = JSON.stringify(entry.metrics, null, 1);
}
if (run.convergence) {
  facts.convergence = `${run.convergence.settled === false ? "NOT SETTLED" : "settled"}: ` +
    JSON.stringify(run.convergence, null, 1);
}
for (const [key, value] of Object.entries(facts)) provenance.append(el("dt", { text: key }), el("dd", { text: value }));

// Track plots.
const sentenceSelect = document.getElementById("sentence");
const coefficientSelect = document.getElementById("coefficient");
const sampleSelect = document.getElementById("sample");
run.sentences.forEach((s, i) => sentenceSelect.append(
  el("option", { value: String(i), text: `${s.subject} / ${s.sentence}` })));

async function drawPlots() {
  const plots = document.getElementById("plots");
  if (!run.sentences.length) {
    plots.replaceChildren(el("p", { class: "note", text: run.tracks_note || "This run stored no tracks." }));
    return;
  }
  const chosen = run.sentences[Number(sentenceSelect.value) || 0];
  const gt = await fetchJSON(`data/sentences/${chosen.subject}/${chosen.sentence}.json`);
  if (!coefficientSelect.options.length) {
    gt.names.forEach((name) => coefficientSelect.append(el("option", { value: name, text: name })));
    coefficientSelect.value = gt.names.includes("jawOpen") ? "jawOpen" : gt.names[0];
  }
  const available = Math.min(chosen.samples, sampleSelect.dataset.max ? Number(sampleSelect.dataset.max) : 99);
  if (sampleSelect.options.length !== available) {
    sampleSelect.replaceChildren(...Array.from({ length: available }, (_, k) => el("option", { value: String(k), text: String(k) })));
  }
  const k = Number(sampleSelect.value) || 0;
  let generated;
  try {
    generated = await fetchJSON(`data/tracks/${encodeURIComponent(runId)}/${chosen.subject}/${chosen.sentence}-${k}.json`);
  } catch (error) {
    sampleSelect.dataset.max = String(k);
    generated = await fetchJSON(`data/tracks/${encodeURIComponent(runId)}/${chosen.subject}/${chosen.sentence}-0.json`);
  }
  const c = gt.names.indexOf(coefficientSelect.value);
  const coeffPlot = linePlot([
    { values: gt.coeffs.map((f) => f[c]), color: "#111", label: "ground truth" },
    { values: generated.coeffs.map((f) => f[c]), color: "#2563eb", label: run.label },
  ], { title: coefficientSelect.value, yLabel: "weight" });
  const maxLip = Math.max(1e-9, ...generated.lip_motion_mm.filter((v) => v !== null), ...gt.lip_motion_mm);
  const lipPlot = linePlot([
    { values: gt.envelope.map((v) => v * maxLip), color: "#aaa", label: "speech envelope (scaled)", dash: "4 2" },
    { values: gt.lip_motion_mm, color: "#111", label: "ground truth" },
    { values: generated.lip_motion_mm, color: "#2563eb", label: run.label },
  ], { title: "lip motion against the speech envelope", yLabel: "mm" });
  coeffPlot.id = "coefficient-plot";
  lipPlot.id = "lip-plot";
  plots.replaceChildren(coeffPlot, el("br"), lipPlot);
  document.getElementById("play-link").href =
    `play.html?subject=${chosen.subject}&sentence=${chosen.sentence}&runs=${encodeURIComponent(runId)}`;
}

for (const select of [sentenceSelect, coefficientSelect, sampleSelect]) select.addEventListener("change", drawPlots);
await drawPlots();
document.body.dataset.ready = "true";
