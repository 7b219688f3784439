// Leaderboard page: one sortable table per dataset showing one metric group at a time (tabs;
// the method column stays in view), the group's charts, and the probability of improvement
// between any two rows for a chosen metric.
import { arrow, el, fetchJSON, fmt, intervalChart, makeSortable, param, rowLabel } from "./site.js";

const NOT_SETTLED = "\u2020";  // the tables' footnote mark

function isAvOffset(name) {
  return name.startsWith("av_offset_") || name.startsWith("av_lag_bias_");
}

function metricCell(row, name, group) {
  const m = row.metrics[name];
  if (!m || m.mean === null) return el("td", { "data-value": "", "data-group": group });
  const cell = el("td", { "data-value": String(m.mean), "data-group": group,
    class: (row.best || []).includes(name) ? "best" : "" }, fmt(m.mean));
  if (m.ci95) cell.append(" ", el("span", { class: "ci", text: `[${fmt(m.ci95[0])}, ${fmt(m.ci95[1])}]` }));
  if (m.seed_range) {
    cell.append(" ", el("span", { class: "seeds", title: "lowest and highest per-seed mean",
      text: `seeds [${fmt(m.seed_range[0])}, ${fmt(m.seed_range[1])}]` }));
  }
  return cell;
}

// the look-ahead probe saw the row read more than one frame (1/60 s) past its declared look-ahead
// (leaderboard.render's ‡; a row declaring none, the whole utterance, never does)
function readsAhead(latency) {
  if (!latency || latency.lookahead_s == null || latency.measured_lookahead_s == null) return false;
  return latency.measured_lookahead_s > latency.lookahead_s + 1 / 60 + 1e-9;
}

function rowElement(row, metrics, groupOf) {
  const label = el("td", { class: "label", "data-value": row.label });
  label.append(el("a", { href: `method.html?run=${encodeURIComponent(row.run)}`, text: row.label }));
  if (row.settled === false) {
    label.append(" ", el("span", { class: "not-settled", title: `not settled: ${row.not_settled || ""}`,
      text: NOT_SETTLED }));
  }
  if (row.samples > 1) label.append(el("span", { class: "ci", text: ` S=${row.samples}` }));
  if (row.seeds && row.seeds.length > 1) {
    label.append(el("span", { class: "ci", text: ` seeds ${row.seeds.join(",")}` }));
  }
  const tr = el("tr", { class: row.reference ? "reference" : "method", "data-run": row.run }, label);
  for (const name of metrics) tr.append(metricCell(row, name, groupOf[name]));
  // real-time factor: wall seconds per second of audio (results without a latency record: "-")
  const rtf = row.latency ? row.latency.rtf : null;
  tr.append(el("td", { class: "rtf", "data-value": rtf === null || rtf === undefined ? "" : String(rtf),
    title: row.latency ? `look-ahead ${row.latency.lookahead_s ?? "whole utterance"} s, first frame ` +
      `${row.latency.first_frame_s ?? "-"} s, CPU ${row.latency.compute_per_audio_s ?? "-"} s per audio s` +
      (row.latency.measured_lookahead_s == null ? "" :
        `, measured look-ahead ${row.latency.measured_lookahead_s} s`) : "" },
    (rtf === null || rtf === undefined ? "-" : fmt(rtf)) + (readsAhead(row.latency) ? " ‡" : "")));
  return tr;
}

function notes(table) {
  const out = [];
  if (table.notes.av_offset) out.push(el("p", { class: "note av-note", text: table.notes.av_offset }));
  const unsettled = [...table.methods, ...table.references].filter((r) => r.settled === false);
  if (unsettled.length) {
    const which = unsettled.map((r) => r.not_settled).join("; ");
    out.push(el("p", { class: "note not-settled-note", text: `${NOT_SETTLED} Not settled (moved by more than the ` +
      `interval's half-width between half and full training budget): ${which}.` }));
  }
  if (table.notes.fallback.length) {
    const labels = table.notes.fallback.map((name) => table.metrics[name].label).join(", ");
    out.push(el("p", { class: "note fallback-note", text: `Best in ${labels} by the older rule (95% interval ` +
      "disjoint from the runner-up's): nothing to resample in these result files (neither per-sentence values nor " +
      `bootstrap replicates, or fewer than ${table.notes.min_sentences} sentences).` }));
  }
  return out;
}

// P(row better than column) for the chosen metric, over paired bootstrap resamples.
function improvementSection(table, index) {
  const names = Object.keys(table.improvement.metrics);
  const section = el("div", { class: "improvement", id: `improvement-${index}` });
  section.append(el("h3", { text: "Probability of improvement" }));
  if (!names.length) {
    section.append(el("p", { class: "note", text: "These result files store nothing to resample." }));
    return section;
  }
  const ordered = table.groups.flatMap((g) => g.metrics).filter((n) => names.includes(n));
  const select = el("select", { class: "improvement-metric" });
  ordered.forEach((name) => select.append(el("option", { value: name,
    text: `${table.metrics[name].label} ${arrow(table.metrics[name].higher_is_better)}` })));
  const holder = el("div");
  const rows = [...table.methods, ...table.references];
  const byRun = Object.fromEntries(rows.map((r) => [r.run, r]));
  const runs = table.improvement.runs;
  function draw() {
    const matrix = table.improvement.metrics[select.value];
    const head = el("tr", {}, el("th", { class: "label", text: "P(row better than column)" }));
    runs.forEach((run) => head.append(el("th", { text: byRun[run].label })));
    const body = el("tbody");
    runs.forEach((run, i) => {
      const tr = el("tr", { "data-row": run, class: byRun[run].reference ? "reference" : "method" },
        el("td", { class: "label", text: byRun[run].label }));
      runs.forEach((other, j) => {
        const p = matrix[i][j];
        const cls = p === null ? "" : p >= 0.95 ? "sure" : p <= 0.05 ? "sure-not" : "";
        tr.append(el("td", { "data-p": p === null ? "" : String(p), class: cls,
          text: p === null ? (i === j ? "" : "–") : `${Math.round(100 * p)}%` }));
      });
      body.append(tr);
    });
    holder.replaceChildren(el("table", { class: "improvement-matrix", "data-metric": select.value },
      el("thead", {}, head), body));
  }
  select.addEventListener("change", draw);
  section.append(el("div", { class: "controls" }, el("label", {}, "metric ", select)),
    el("p", { class: "note", text: "Fraction of paired bootstrap resamples (the same resampled sentences for both " +
      "rows, training seeds resampled too for rows trained with several) in which the row's value is better than " +
      "the column's; ties count half. A method is in bold in the table only where it beats the runner-up in at " +
      "least 95%." }), holder);
  draw();
  return section;
}

function renderTable(table, index) {
  const section = el("section", { id: `table-${index}` });
  section.append(el("h2", { text: `${table.name ? `${table.name}: d` : "D"}ataset ` +
    `${table.manifest_hash.slice(0, 12)} — ${table.split} split, ${table.num_sentences ?? "?"} sentences` }));
  if (table.latent_out_of_domain) {
    section.append(el("p", { class: "note", text: "The latent metrics (FD, WInD, multimodality, energy_latent) " +
      "use the published VAE, trained on BlendVOCA: out of domain on this dataset (docs/datasets.md)." }));
  }
  if (table.vae) {
    section.append(el("p", { class: "note vae", text: "The latent metrics (FD, WInD, multimodality, energy_latent) " +
      `are scored by the VAE of sha256 ${table.vae.slice(0, 12)} (each result's protocol.vae), trained on this ` +
      "dataset's training split, not the published one." }));
  }
  const metrics = table.groups.flatMap((g) => g.metrics);
  const groupRow = el("tr", {}, el("th", { class: "label", rowspan: "2", text: "method" }));
  const groupOf = Object.fromEntries(table.groups.flatMap((g) => g.metrics.map((name) => [name, g.name])));
  for (const group of table.groups) {
    groupRow.append(el("th", { colspan: String(group.metrics.length), "data-group": group.name, text: group.name }));
  }
  groupRow.append(el("th", { rowspan: "2", class: "sortable rtf", "data-column": String(metrics.length + 1),
    title: "real-time factor: wall seconds of generation per second of audio (below 1: faster than the speech)",
    text: "RTF" }));
  const metricRow = el("tr");
  metrics.forEach((name, i) => {
    const spec = table.metrics[name];
    let title = `${name}${spec.unit ? ` (${spec.unit})` : ""}`;
    if (isAvOffset(name) && table.notes.av_offset) title += `\n${table.notes.av_offset}`;
    const th = el("th", { class: "sortable", "data-column": String(i + 1), "data-metric": name,
      "data-group": groupOf[name], title });
    th.textContent = `${spec.label} ${arrow(spec.higher_is_better)}`;
    if (table.best_rule[name] === "intervals") th.classList.add("fallback");
    metricRow.append(th);
  });
  const methods = el("tbody", { class: "methods" });
  table.methods.forEach((row) => methods.append(rowElement(row, metrics, groupOf)));
  const references = el("tbody", { class: "references" });
  references.append(el("tr", { class: "separator" },
    el("td", { colspan: String(metrics.length + 2), text: "reference and sanity rows (not ranked)" })));
  table.references.forEach((row) => references.append(rowElement(row, metrics, groupOf)));
  const tableEl = el("table", { class: "leaderboard" }, el("thead", {}, groupRow, metricRow), methods, references);
  makeSortable(tableEl);
  // one metric group at a time: tabs above the table; the same tab picks the charts below
  const tabs = el("div", { class: "tabs", role: "tablist" });
  const show = (name) => {
    section.querySelectorAll("[data-group]").forEach((node) => { node.hidden = node.dataset.group !== name; });
    tabs.querySelectorAll("button").forEach((b) => b.setAttribute("aria-selected", String(b.dataset.tab === name)));
    section.dataset.shownGroup = name;
    const shown = (table.groups.find((g) => g.name === name) || { metrics: [] }).metrics.length;
    section.querySelectorAll("tr.separator td").forEach((td) => { td.colSpan = shown + 2; });
  };
  for (const group of table.groups) {
    tabs.append(el("button", { type: "button", role: "tab", "data-tab": group.name,
      title: group.metrics.map((n) => table.metrics[n].label).join(", "),
      text: `${group.name} (${group.metrics.length})`, onclick: () => show(group.name) }));
  }
  section.append(tabs, el("div", { class: "table-scroll" }, tableEl), ...notes(table));

  for (const group of table.groups) {
    const charts = el("div", { class: "charts", "data-group": group.name });
    for (const name of group.metrics) {
      const spec = table.metrics[name];
      const rows = [...table.methods, ...table.references].map((row) => {
        const m = row.metrics[name] || {};
        return { label: rowLabel(row), run: row.run, reference: row.reference, mean: m.mean ?? null,
          lo: m.ci95 ? m.ci95[0] : null, hi: m.ci95 ? m.ci95[1] : null };
      });
      if (!rows.some((r) => r.mean !== null)) continue;
      charts.append(el("div", { class: "chart", "data-metric": name },
        intervalChart(rows, { title: spec.label, unit: spec.unit, higherIsBetter: spec.higher_is_better })));
    }
    section.append(el("h3", { "data-group": group.name, text: `${group.name}: one chart per metric` }), charts);
  }
  section.append(improvementSection(table, index));
  const wanted = table.groups.find((g) => g.name === param("group"));
  show((wanted || table.groups[0]).name);
  return section;
}

const data = await fetchJSON("data/leaderboard.json");
const root = document.getElementById("tables");
data.tables.forEach((table, i) => root.append(renderTable(table, i)));
document.body.dataset.ready = "true";
