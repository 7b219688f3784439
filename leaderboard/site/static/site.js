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
  const decimals = Math.max(0, Math.min(5, digits - 1 - magnitude));
  return value.toFixed(decimals);
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
  const root = svg("svg", { width, height, viewBox: `0 0 ${width} ${height}` });
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
    legendX -= 12 + 6.5 * s.label.length;
  }
  for (const s of series) {
    const points = s.values.map((v, i) => (v === null ? null : `${x(i).toFixed(1)},${y(v).toFixed(1)}`)).filter(Boolean);
    root.append(svg("polyline", { points: points.join(" "), fill: "none", stroke: s.color, "stroke-width": 1.5,
      "stroke-dasharray": s.dash || "" }));
  }
  return root;
}

// Points with interval bars, one per row: rows = [{label, mean, lo, hi, reference}].
export function intervalChart(rows, { title = "", unit = "", higherIsBetter = null, width = 320 } = {}) {
  const rowHeight = 18, pad = { left: 150, right: 16, top: 26, bottom: 26 };
  const height = pad.top + pad.bottom + rowHeight * rows.length;
  const root = svg("svg", { width, height, viewBox: `0 0 ${width} ${height}` });
  const values = rows.flatMap((r) => [r.mean, r.lo, r.hi]).filter((v) => v !== null && v !== undefined);
  let lo = Math.min(...values), hi = Math.max(...values);
  if (!(hi > lo)) { lo -= 1; hi += 1; }
  const margin = 0.05 * (hi - lo); lo -= margin; hi += margin;
  const x = (v) => pad.left + ((v - lo) / (hi - lo)) * (width - pad.left - pad.right);
  const caption = svg("text", { x: 4, y: 14, "font-size": 12 });
  caption.textContent = `${title} ${arrow(higherIsBetter)}${unit ? ` (${unit})` : ""}`;
  root.append(caption);
  rows.forEach((r, i) => {
    const cy = pad.top + rowHeight * i + rowHeight / 2;
    const label = svg("text", { x: pad.left - 6, y: cy + 4, "text-anchor": "end", "font-size": 11,
      fill: r.reference ? "#888" : "#222" });
    label.textContent = r.label;
    root.append(label);
    if (r.mean === null || r.mean === undefined) return;
    const color = r.reference ? "#999" : "#2563eb";
    if (r.lo !== null && r.lo !== undefined && r.hi !== null && r.hi !== undefined) {
      root.append(svg("line", { x1: x(r.lo), x2: x(r.hi), y1: cy, y2: cy, stroke: color, "stroke-width": 2 }));
    }
    root.append(svg("circle", { cx: x(r.mean), cy, r: 3.5, fill: color }));
  });
  for (const v of [lo + margin, hi - margin]) {
    const t = svg("text", { x: x(v), y: height - 8, "text-anchor": "middle", "font-size": 10 });
    t.textContent = fmt(v, 3);
    root.append(t);
  }
  return root;
}
