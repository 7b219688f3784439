// Shared helpers of the results browser pages: data fetching, number formatting,
// sortable tables and small SVG plots. No dependencies.

// A page whose data did not load says so on the page, not only in the console.
window.addEventListener("unhandledrejection", (event) => {
  const note = document.createElement("div");
  note.className = "warning load-error";
  note.textContent = `This page could not load its data: ${event.reason && event.reason.message || event.reason}`;
  document.body.prepend(note);
});

export async function fetchJSON(path) {
  const response = await fetch(path);
  if (!response.ok) throw new Error(`${path}: HTTP ${response.status}`);
  return response.json();
}

export function param(name) {
  return new URLSearchParams(window.location.search).get(name);
}

export function fmt(value, digits = 3) {
  if (value === null || value === undefined || Number.isNaN(value)) return "";
  if (Math.abs(value) < 1e-9) return "0";  // numerical zeros (e.g. FD of the ground truth) print as 0
  const magnitude = Math.floor(Math.log10(Math.abs(value)));
  // tiny values in scientific notation, never as "-0.00000"
  if (magnitude < -3) return value.toExponential(Math.max(0, digits - 2));
  const decimals = Math.max(0, Math.min(5, digits - 1 - magnitude));
  const text = value.toFixed(decimals);
  return /^-0(\.0*)?$/.test(text) ? text.slice(1) : text;
}

// A label for a row: its name, samples and training seeds ("said (S=5, seeds 0,1,2)").
export function rowLabel(row) {
  const extras = [];
  if (row.samples > 1) extras.push(`S=${row.samples}`);
  if (row.seeds && row.seeds.length > 1) extras.push(`seeds ${row.seeds.join(",")}`);
  return extras.length ? `${row.label} (${extras.join(", ")})` : row.label;
}

// The SVG charts draw their text in this font and measure it with a canvas in the same font,
// so margins fit the longest label (never clipped).
export const CHART_FONT = "Arial, Helvetica, sans-serif";
const measureContext = document.createElement("canvas").getContext("2d");

export function textWidth(text, size = 11) {
  measureContext.font = `${size}px ${CHART_FONT}`;
  return measureContext.measureText(String(text)).width;
}

// Round tick values covering [lo, hi]: steps of 1, 2 or 5 times a power of ten.
export function linearTicks(lo, hi, count = 5) {
  const raw = (hi - lo) / Math.max(1, count);
  const power = 10 ** Math.floor(Math.log10(raw));
  const step = [1, 2, 5, 10].map((m) => m * power).find((s) => s >= raw);
  const ticks = [];
  for (let v = Math.ceil(lo / step - 1e-9) * step; v <= hi + 1e-9 * step; v += step) {
    ticks.push(Math.abs(v) < step * 1e-9 ? 0 : v);
  }
  return { ticks, decimals: Math.max(0, -Math.floor(Math.log10(step) + 1e-9)) };
}

// Ticks of a log axis: 1, 2, 5 times powers of ten inside [lo, hi] (lo > 0).
export function logTicks(lo, hi) {
  const ticks = [];
  for (let p = Math.floor(Math.log10(lo)); p <= Math.ceil(Math.log10(hi)); p++) {
    for (const m of [1, 2, 5]) {
      const v = m * 10 ** p;
      if (v >= lo * (1 - 1e-9) && v <= hi * (1 + 1e-9)) ticks.push(v);
    }
  }
  return ticks.length > 8 ? ticks.filter((v) => Math.abs(Math.log10(v) % 1) < 1e-9) : ticks;
}

export function tickText(value, decimals = null) {
  if (value === 0) return "0";
  if (decimals !== null && Math.abs(value) >= 1e-3) return value.toFixed(decimals);
  if (Math.abs(value) >= 1e4 || Math.abs(value) < 1e-3) return value.toExponential(0).replace("+", "");
  return String(Number(value.toPrecision(3)));
}

export function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(attrs)) {
    if (key === "class") node.className = value;
    else if (key === "text") node.textContent = value;
    else if (key.startsWith("on")) node.addEventListener(key.slice(2), value);
    else node.setAttribute(key, value);
  }
  for (const child of children) node.append(child);
  return node;
}

export function arrow(higherIsBetter) {
  return higherIsBetter === true ? "\u2191" : higherIsBetter === false ? "\u2193" : "";
}

// Sort the <tr> of each <tbody> of `table` (bodies sort independently, so reference
// rows stay apart) by the numeric data-value of the clicked column.
export function makeSortable(table) {
  const headers = table.querySelectorAll("th.sortable");
  headers.forEach((th) => {
    th.addEventListener("click", () => {
      const column = Number(th.dataset.column);
      const descending = !th.classList.contains("sorted-desc");
      headers.forEach((h) => h.classList.remove("sorted-asc", "sorted-desc"));
      th.classList.add(descending ? "sorted-desc" : "sorted-asc");
      sortBodies(table, column, descending);
    });
  });
}

export function sortBodies(table, column, descending) {
  for (const body of table.tBodies) {
    const rows = Array.from(body.rows).filter((r) => !r.classList.contains("separator"));
    const separator = Array.from(body.rows).filter((r) => r.classList.contains("separator"));
    const key = (row) => {
      const cell = row.cells[column];
      const raw = cell ? cell.dataset.value : undefined;
      if (raw === undefined || raw === "") return null;
      const number = Number(raw);
      return Number.isNaN(number) ? raw : number;
    };
    rows.sort((a, b) => {
      const ka = key(a), kb = key(b);
      if (ka === null && kb === null) return 0;
      if (ka === null) return 1;
      if (kb === null) return -1;
      const order = typeof ka === "number" && typeof kb === "number" ? ka - kb : String(ka).localeCompare(String(kb));
      return descending ? -order : order;
    });
    body.replaceChildren(...separator, ...rows);
  }
}

const SVG = "http://www.w3.org/2000/svg";

export function svg(tag, attrs = {}) {
  const node = document.createElementNS(SVG, tag);
  for (const [key, value] of Object.entries(attrs)) node.setAttribute(key, value);
  return node;
}

// Line plot of several series over frames: series = [{values, color, label, dash}].
export function linePlot(series, { width = 640, height = 200, fps = 60, title = "", yLabel = "" } = {}) {
  const pad = { left: 48, right: 10, top: 34, bottom: 28 };
  const root = svg("svg", { width, height, viewBox: `0 0 ${width} ${height}`, "font-family": CHART_FONT });
  const all = series.flatMap((s) => s.values.filter((v) => v !== null));
  const length = Math.max(1, ...series.map((s) => s.values.length));
  let lo = Math.min(0, ...all), hi = Math.max(...all, lo + 1e-9);
  const x = (i) => pad.left + (i / Math.max(1, length - 1)) * (width - pad.left - pad.right);
  const y = (v) => height - pad.bottom - ((v - lo) / (hi - lo)) * (height - pad.top - pad.bottom);
  root.append(svg("line", { x1: pad.left, y1: y(lo), x2: width - pad.right, y2: y(lo), stroke: "#999" }));
  root.append(svg("line", { x1: pad.left, y1: pad.top, x2: pad.left, y2: height - pad.bottom, stroke: "#999" }));
  for (const v of [lo, hi]) {
    const t = svg("text", { x: pad.left - 4, y: y(v) + 4, "text-anchor": "end", "font-size": 10 });
    t.textContent = fmt(v, 2);
    root.append(t);
  }
  const seconds = (length - 1) / fps;
  for (let s = 0; s <= seconds + 1e-9; s += Math.max(0.5, Math.ceil(seconds / 8 * 2) / 2)) {
    const t = svg("text", { x: x(s * fps), y: height - 10, "text-anchor": "middle", "font-size": 10 });
    t.textContent = `${s.toFixed(1)} s`;
    root.append(t);
  }
  const caption = svg("text", { x: pad.left, y: 14, "font-size": 12 });
  caption.textContent = title + (yLabel ? ` (${yLabel})` : "");
  root.append(caption);
  let legendX = width - pad.right;
  for (const s of [...series].reverse()) {
    const label = svg("text", { x: legendX, y: 27, "text-anchor": "end", "font-size": 11, fill: s.color });
    label.textContent = s.label;
    root.append(label);
    legendX -= 12 + textWidth(s.label, 11);  // measured: legends never overlap
  }
  for (const s of series) {
    const points = s.values.map((v, i) => (v === null ? null : `${x(i).toFixed(1)},${y(v).toFixed(1)}`)).filter(Boolean);
    root.append(svg("polyline", { points: points.join(" "), fill: "none", stroke: s.color, "stroke-width": 1.5,
      "stroke-dasharray": s.dash || "" }));
  }
  return root;
}

// Points with interval bars, one per row: rows = [{label, run, mean, lo, hi, reference}].
// The axis spans the ranked rows only (a log axis where they spread over more than a
// factor of 10); reference rows get their own rows below, a dotted line through the
// ranked rows where their value is on the axis, and an arrow with the value at the edge
// where it is not. Margins are measured from the labels, so no text is clipped.
export function intervalChart(rows, { title = "", unit = "", higherIsBetter = null, width = 900 } = {}) {
  const font = 11, rowHeight = 20, plotMin = 280;
  const has = (v) => v !== null && v !== undefined && Number.isFinite(v);
  const ranked = rows.filter((r) => !r.reference);
  const references = rows.filter((r) => r.reference);
  const scaleRows = ranked.some((r) => has(r.mean)) ? ranked : references;
  const values = scaleRows.flatMap((r) => [r.mean, r.lo, r.hi]).filter(has);
  let lo = Math.min(...values), hi = Math.max(...values);
  const log = lo > 0 && hi / lo >= 10;
  let ticks, decimals = null;
  if (log) {
    lo /= 1.15; hi *= 1.15;
    ticks = logTicks(lo, hi);
  } else {
    if (!(hi > lo)) { const d = Math.abs(hi) > 0 ? 0.1 * Math.abs(hi) : 1; lo -= d; hi += d; }
    const margin = 0.06 * (hi - lo); lo -= margin; hi += margin;
    ({ ticks, decimals } = linearTicks(lo, hi, 5));
  }
  const tickLabels = ticks.map((v) => tickText(v, decimals));
  const labels = rows.map((r) => r.label);
  const pad = { left: Math.ceil(Math.max(...labels.map((t) => textWidth(t, font)), 40)) + 12,
    right: Math.ceil(Math.max(8, textWidth(tickLabels[tickLabels.length - 1] || "", 10) / 2 + 4)),
    top: 30, bottom: 30 };
  width = Math.max(width, pad.left + pad.right + plotMin);
  const gap = references.length ? rowHeight : 0;  // the "reference (not ranked)" line
  const height = pad.top + pad.bottom + rowHeight * rows.length + gap;
  const root = svg("svg", { width, height, viewBox: `0 0 ${width} ${height}`, "font-family": CHART_FONT,
    class: log ? "log-axis" : "linear-axis" });
  const left = pad.left, right = width - pad.right;
  Object.assign(root.dataset, { plotLeft: String(left), plotRight: String(right) });
  const x = log
    ? (v) => left + ((Math.log10(v) - Math.log10(lo)) / (Math.log10(hi) - Math.log10(lo))) * (right - left)
    : (v) => left + ((v - lo) / (hi - lo)) * (right - left);
  const inRange = (v) => has(v) && v >= lo && v <= hi && (!log || v > 0);
  const clamp = (v) => (log && v <= 0 ? left : Math.max(left, Math.min(right, x(v))));
  const rankedBottom = pad.top + rowHeight * ranked.length;
  const plotBottom = height - pad.bottom;

  const caption = svg("text", { x: 4, y: 16, "font-size": 12, "font-weight": "bold", class: "chart-title" });
  caption.textContent = `${title} ${arrow(higherIsBetter)}${unit ? ` (${unit})` : ""}${log ? ", log axis" : ""}`;
  root.append(caption);
  ticks.forEach((v, k) => {
    root.append(svg("line", { x1: x(v), x2: x(v), y1: pad.top - 4, y2: plotBottom, stroke: "#eee" }));
    const t = svg("text", { x: x(v), y: height - 12, "text-anchor": "middle", "font-size": 10, class: "tick" });
    t.textContent = tickLabels[k];
    root.append(t);
  });
  root.append(svg("line", { x1: left, x2: right, y1: plotBottom, y2: plotBottom, stroke: "#999" }));

  const rowY = (r, i) => pad.top + rowHeight * i + rowHeight / 2 + (r.reference ? gap : 0);
  if (references.length) {
    const note = svg("text", { x: 4, y: rankedBottom + gap / 2 + 4, "font-size": 10, "font-style": "italic",
      fill: "#777", class: "separator" });
    note.textContent = "reference rows (not ranked, not setting the axis)";
    root.append(note);
  }
  rows.forEach((r, i) => {
    const cy = rowY(r, i);
    const label = svg("text", { x: left - 6, y: cy + 4, "text-anchor": "end", "font-size": font,
      fill: r.reference ? "#777" : "#222", class: "row-label" });
    label.textContent = r.label;
    root.append(label);
    if (!has(r.mean)) return;
    const color = r.reference ? "#888" : "#2563eb";
    if (has(r.lo) && has(r.hi)) {
      const x1 = clamp(r.lo), x2 = clamp(r.hi);
      if (x2 > x1) root.append(svg("line", { x1, x2, y1: cy, y2: cy, stroke: color, "stroke-width": 2 }));
    }
    if (!r.reference) {
      const mark = svg("circle", { cx: x(r.mean), cy, r: 4, fill: color, class: "mark ranked" });
      mark.dataset.run = r.run || r.label;
      mark.append(svg("title"));
      mark.firstChild.textContent = `${r.label}: ${fmt(r.mean)}`;
      root.append(mark);
      return;
    }
    if (inRange(r.mean)) {
      const cx = x(r.mean);
      root.append(svg("line", { x1: cx, x2: cx, y1: pad.top - 4, y2: rankedBottom, stroke: "#999",
        "stroke-dasharray": "2 3", class: "reference-line" }));
      const mark = svg("path", { d: `M${cx} ${cy - 5}L${cx + 5} ${cy}L${cx} ${cy + 5}L${cx - 5} ${cy}Z`,
        fill: color, class: "mark reference" });
      mark.dataset.run = r.run || r.label;
      root.append(mark);
    } else {
      // off the axis: an arrow at the edge it lies beyond, with its value
      const beyondRight = r.mean > hi;
      const ex = beyondRight ? right : left;
      const d = beyondRight ? `M${ex} ${cy}L${ex - 8} ${cy - 5}L${ex - 8} ${cy + 5}Z`
        : `M${ex} ${cy}L${ex + 8} ${cy - 5}L${ex + 8} ${cy + 5}Z`;
      const mark = svg("path", { d, fill: color, class: "mark reference off-axis" });
      mark.dataset.run = r.run || r.label;
      root.append(mark);
      const t = svg("text", { x: beyondRight ? ex - 11 : ex + 11, y: cy + 4, "font-size": 10, fill: "#555",
        "text-anchor": beyondRight ? "end" : "start", class: "off-axis-value" });
      t.textContent = fmt(r.mean);
      root.append(t);
    }
  });
  return root;
}
