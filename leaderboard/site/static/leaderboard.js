// Leaderboard page: one grouped, sortable table per dataset and a chart per metric group.
import { arrow, el, fetchJSON, fmt, intervalChart, makeSortable } from "./site.js";

function metricCell(row, name) {
  const m = row.metrics[name];
  if (!m || m.mean === null) return el("td", { "data-value": "" });
  const cell = el("td", { "data-value": String(m.mean), class: (row.best || []).includes(name) ? "best" : "" },
    fmt(m.mean));
  if (m.ci95) cell.append(" ", el("span", { class: "ci", text: `[${fmt(m.ci95[0])}, ${fmt(m.ci95[1])}]` }));
  return cell;
}

function rowElement(row, metrics) {
  const label = el("td", { class: "label", "data-value": row.label });
  label.append(el("a", { href: `method.html?run=${encodeURIComponent(row.run)}`, text: row.label }));
  if (row.samples > 1) label.append(el("span", { class: "ci", text: ` S=${row.samples}` }));
  const tr = el("tr", { class: row.reference ? "reference" : "method", "data-run": row.run }, label);
  for (const name of metrics) tr.append(metricCell(row, name));
  return tr;
}

function renderTable(table, index) {
  const section = el("section", { id: `table-${index}` });
  section.append(el("h2", { text: `Dataset ${table.manifest_hash.slice(0, 12)} — ${table.split} split, ` +
    `${table.num_sentences ?? "?"} sentences` }));
  const metrics = table.groups.flatMap((g) => g.metrics);
  const groupRow = el("tr", {}, el("th", { class: "label", rowspan: "2", text: "method" }));
  for (const group of table.groups) groupRow.append(el("th", { colspan: String(group.metrics.length), text: group.name }));
  const metricRow = el("tr");
  metrics.forEach((name, i) => {
    const spec = table.metrics[name];
    const th = el("th", { class: "sortable", "data-column": String(i + 1), "data-metric": name,
      title: `${name}${spec.unit ? ` (${spec.unit})` : ""}` });
    th.textContent = `${spec.label} ${arrow(spec.higher_is_better)}`;
    metricRow.append(th);
  });
  const methods = el("tbody", { class: "methods" });
  table.methods.forEach((row) => methods.append(rowElement(row, metrics)));
  const references = el("tbody", { class: "references" });
  references.append(el("tr", { class: "separator" },
    el("td", { colspan: String(metrics.length + 1), text: "reference and sanity rows (not ranked)" })));
  table.references.forEach((row) => references.append(rowElement(row, metrics)));
  const tableEl = el("table", { class: "leaderboard" }, el("thead", {}, groupRow, metricRow), methods, references);
  makeSortable(tableEl);
  section.append(tableEl);

  for (const group of table.groups) {
    const charts = el("div", { class: "charts" });
    for (const name of group.metrics) {
      const spec = table.metrics[name];
      const rows = [...table.methods, ...table.references].map((row) => {
        const m = row.metrics[name] || {};
        return { label: row.label, reference: row.reference, mean: m.mean ?? null,
          lo: m.ci95 ? m.ci95[0] : null, hi: m.ci95 ? m.ci95[1] : null };
      });
      if (!rows.some((r) => r.mean !== null)) continue;
      charts.append(el("div", { class: "chart", "data-metric": name },
        intervalChart(rows, { title: spec.label, unit: spec.unit, higherIsBetter: spec.higher_is_better })));
    }
    section.append(el("h3", { text: group.name }), charts);
  }
  return section;
}

const data = await fetchJSON("data/leaderboard.json");
const root = document.getElementById("tables");
data.tables.forEach((table, i) => root.append(renderTable(table, i)));
document.body.dataset.ready = "true";
