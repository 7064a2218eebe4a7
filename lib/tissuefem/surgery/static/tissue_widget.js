// The browser side of tissuefem.surgery.widget.TissueWidget: draws a triangle mesh on a 2D canvas from binary
// arrays the kernel sends, and sends the pointer back in world coordinates.
//
// Data model (the widget's traitlets):
//   dim          coordinates per point (2; a 3D view sends 3 and this renderer draws x, y)
//   positions    float32 bytes, (n_points, dim) row-major: sent every frame the tissue moved
//   triangles    int32 bytes, (n_triangles, 3): sent only when the topology changes (a cut)
//   edges        int32 bytes, (n_edges, 2): the lines drawn over the faces, sent with the triangles
//   outline      int32 bytes: the boundary loops of point indices, each ended by -1; filled (nonzero rule) instead
//                of every triangle when there are no colours (far cheaper to rasterise without a GPU)
//   colors       float32 bytes, one value per triangle, or empty (one fill colour); mapped over color_range
//   bounds       [xmin, xmax, ymin, ymax]: the world box shown (equal aspect, centred)
//   target       [x, y] of the drag target, or []; stroke: float32 bytes (k, 2) of the cut stroke being drawn
//   readout, message, mode ("drag" or "cut"), width, height (CSS pixels)
//   running      whether the kernel's frame loop runs: the run button shows "pause" (running) or "run" (paused)
//   disabled     a view that stopped: the buttons and the pointer do nothing
// Pointer messages to the kernel: {event: "pointer", kind: "down" | "move" | "up", x, y, inside}.
// A picture is painted with requestAnimationFrame only when something new arrived: nothing runs at rest. The canvas
// carries the paint count (data-painted), the world-to-pixel map (data-view: [scale, ox, oy], CSS pixels of its
// content box: px = ox + scale * x, py = oy - scale * y) and, as canvas.tissuefem.log, the last paints' times,
// drag targets and milliseconds spent, for tests and benchmarks.

const FILL = "#ffe4e1"; // matplotlib's "mistyrose", as the static snapshot
const EDGE = "#b22222"; // "firebrick"
const TARGET = "#1f77b4"; // "tab:blue"

function floats(value) {
  if (!value) return new Float32Array(0);
  if (value instanceof DataView) return new Float32Array(value.buffer, value.byteOffset, value.byteLength / 4);
  if (value instanceof ArrayBuffer) return new Float32Array(value);
  if (ArrayBuffer.isView(value)) return new Float32Array(value.buffer, value.byteOffset, value.byteLength / 4);
  return new Float32Array(0);
}

function ints(value) {
  if (!value) return new Int32Array(0);
  if (value instanceof DataView) return new Int32Array(value.buffer, value.byteOffset, value.byteLength / 4);
  if (value instanceof ArrayBuffer) return new Int32Array(value);
  if (ArrayBuffer.isView(value)) return new Int32Array(value.buffer, value.byteOffset, value.byteLength / 4);
  return new Int32Array(0);
}

// a diverging map around the middle of the range: blue (shrunk) - white - red (stretched), in 32 bins
const BINS = 32;
function binColor(k) {
  const t = (k + 0.5) / BINS; // 0..1
  const a = Math.abs(2 * t - 1);
  const [r, g, b] = t < 0.5 ? [255 - 200 * a, 255 - 140 * a, 255] : [255, 255 - 200 * a, 255 - 200 * a];
  return `rgb(${r | 0},${g | 0},${b | 0})`;
}

function render({ model, el }) {
  const root = document.createElement("div");
  root.className = "tissuefem-view";
  root.tabIndex = 0; // takes the keyboard after a click: the key c toggles the mode
  root.style.cssText = "display:inline-block;font:12px monospace;outline:none;user-select:none;";
  const bar = document.createElement("div");
  bar.style.cssText = "display:flex;gap:6px;align-items:center;margin-bottom:2px;";
  const buttons = {};
  for (const mode of ["drag", "cut"]) {
    const b = document.createElement("button");
    b.textContent = mode;
    b.className = "tissuefem-mode";
    b.dataset.mode = mode;
    b.style.cssText = "font:12px monospace;padding:1px 8px;";
    b.addEventListener("click", () => setMode(mode));
    bar.appendChild(b);
    buttons[mode] = b;
  }
  const run = document.createElement("button");
  run.className = "tissuefem-run";
  run.style.cssText = "font:12px monospace;padding:1px 8px;min-width:7em;";
  run.addEventListener("click", () => {
    model.set("running", !model.get("running"));
    model.save_changes();
  });
  bar.appendChild(run);
  const readout = document.createElement("span");
  readout.className = "tissuefem-readout";
  readout.style.whiteSpace = "pre";
  bar.appendChild(readout);
  const canvas = document.createElement("canvas");
  canvas.className = "tissuefem-canvas";
  canvas.style.cssText = "display:block;border:1px solid #ccc;touch-action:none;cursor:crosshair;";
  canvas.dataset.painted = "0";
  const message = document.createElement("div");
  message.className = "tissuefem-message";
  message.style.cssText = "color:#b22222;min-height:1.3em;white-space:pre-wrap;";
  root.append(bar, canvas, message);
  el.appendChild(root);
  const ctx = canvas.getContext("2d");

  const state = {positions: null, triangles: null, edges: null, outline: null, colors: null, stroke: null};
  let painted = 0, pending = false, paintTimes = [];
  let map = [1, 0, 0];
  const log = [];
  canvas.tissuefem = {log: log};

  function load(name) {
    const v = model.get(name);
    if (name === "triangles" || name === "edges" || name === "outline") state[name] = ints(v);
    else state[name] = floats(v);
  }
  for (const name of ["positions", "triangles", "edges", "outline", "colors", "stroke"]) load(name);

  function setMode(mode) {
    if (model.get("mode") === mode) return;
    model.set("mode", mode);
    model.save_changes();
  }

  function showMode() {
    const current = model.get("mode");
    for (const [mode, b] of Object.entries(buttons)) b.style.fontWeight = current === mode ? "bold" : "normal";
    canvas.style.cursor = model.get("mode") === "cut" ? "crosshair" : "grab";
  }

  function showRunning() {
    // a different symbol and word in each state: what a click does next
    const running = model.get("running");
    run.textContent = running ? "\u23F8 pause" : "\u25B6 run";
    run.title = running ? "pause the frames" : "run a frame every 33 ms while something changes";
    run.dataset.running = running ? "1" : "0";
    const off = model.get("disabled");
    for (const b of [run, ...Object.values(buttons)]) b.disabled = off;
    canvas.style.opacity = off ? "0.6" : "1";
  }

  function size() {
    const w = model.get("width"), h = model.get("height"), dpr = window.devicePixelRatio || 1;
    canvas.style.width = `${w}px`;
    canvas.style.height = `${h}px`;
    canvas.width = Math.round(w * dpr);
    canvas.height = Math.round(h * dpr);
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  }

  function fit() {
    const [x0, x1, y0, y1] = model.get("bounds");
    const w = model.get("width"), h = model.get("height");
    const s = Math.min(w / (x1 - x0 || 1), h / (y1 - y0 || 1));
    map = [s, (w - s * (x1 - x0)) / 2 - s * x0, h - (h - s * (y1 - y0)) / 2 + s * y0];
    canvas.dataset.view = JSON.stringify(map);
  }

  function request() {
    if (!pending) {
      pending = true;
      requestAnimationFrame(paint);
    }
  }

  function paint() {
    pending = false;
    const started = performance.now();
    const w = model.get("width"), h = model.get("height");
    const [s, ox, oy] = map;
    const dim = model.get("dim") || 2;
    const x = state.positions, t = state.triangles, e = state.edges, c = state.colors;
    ctx.clearRect(0, 0, w, h);
    const n = x ? x.length / dim : 0;
    if (n > 0 && t.length > 0) {
      const px = (i) => ox + s * x[dim * i];
      const py = (i) => oy - s * x[dim * i + 1];
      const nt = t.length / 3;
      const colored = c && c.length === nt;
      const [lo, hi] = model.get("color_range");
      const o = state.outline;
      const paths = colored ? Array.from({length: BINS}, () => new Path2D()) : [new Path2D()];
      // no colours: fill the boundary loops; else every triangle (no closePath: a fill closes each one, and
      // thousands of closePath calls cost far more than the fill)
      if (!colored && o && o.length > 0) {
        let first = true;
        for (let k = 0; k < o.length; k++) {
          const a = o[k];
          if (a < 0 || a >= n) {
            first = true;
            continue;
          }
          if (first) paths[0].moveTo(px(a), py(a));
          else paths[0].lineTo(px(a), py(a));
          first = false;
        }
      }
      else for (let k = 0; k < nt; k++) {
        const a = t[3 * k], b = t[3 * k + 1], d = t[3 * k + 2];
        if (a >= n || b >= n || d >= n) continue; // a frame between new triangles and their positions
        let bin = 0;
        if (colored) bin = Math.max(0, Math.min(BINS - 1, Math.floor(((c[k] - lo) / (hi - lo || 1)) * BINS)));
        const p = paths[bin];
        p.moveTo(px(a), py(a));
        p.lineTo(px(b), py(b));
        p.lineTo(px(d), py(d));
      }
      paths.forEach((p, k) => {
        ctx.fillStyle = colored ? binColor(k) : FILL;
        ctx.fill(p);
      });
      const lines = new Path2D();
      for (let k = 0; k < e.length; k += 2) {
        const a = e[k], b = e[k + 1];
        if (a >= n || b >= n) continue;
        lines.moveTo(px(a), py(a));
        lines.lineTo(px(b), py(b));
      }
      ctx.strokeStyle = EDGE;
      ctx.lineWidth = 0.5;
      ctx.stroke(lines);
    }
    const st = state.stroke;
    if (st && st.length >= 2) {
      ctx.beginPath();
      ctx.moveTo(ox + s * st[0], oy - s * st[1]);
      for (let k = 2; k < st.length; k += 2) ctx.lineTo(ox + s * st[k], oy - s * st[k + 1]);
      ctx.strokeStyle = "#000";
      ctx.lineWidth = 1.5;
      ctx.stroke();
    }
    const target = model.get("target");
    if (target && target.length >= 2) {
      ctx.beginPath();
      ctx.arc(ox + s * target[0], oy - s * target[1], 5, 0, 2 * Math.PI);
      ctx.strokeStyle = TARGET;
      ctx.lineWidth = 2;
      ctx.stroke();
    }
    painted++;
    canvas.dataset.painted = String(painted);
    const now = performance.now();
    // the last paints, [time, target x, target y], for a test or benchmark to time the pointer against
    const shown = target && target.length >= 2;
    log.push([now, shown ? target[0] : null, shown ? target[1] : null, now - started]);
    if (log.length > 2000) log.splice(0, 1000);
    paintTimes.push(now);
    while (paintTimes.length && paintTimes[0] < now - 1000) paintTimes.shift();
    showReadout();
  }

  function showReadout() {
    // the kernel's line, and the pictures painted in the last second (counted here: nothing sent for it)
    const now = performance.now(); // a paused or resting view paints nothing: its count falls to 0
    while (paintTimes.length && paintTimes[0] < now - 1000) paintTimes.shift();
    const lines = model.get("readout").split("\n");
    lines[0] += ` | ${paintTimes.length} painted/s`;
    readout.textContent = lines.join("\n");
  }

  function world(event) {
    const r = canvas.getBoundingClientRect();
    const [s, ox, oy] = map;
    const cx = event.clientX - r.left - canvas.clientLeft, cy = event.clientY - r.top - canvas.clientTop;
    const inside = cx >= 0 && cy >= 0 && cx <= canvas.clientWidth && cy <= canvas.clientHeight;
    return {x: (cx - ox) / s, y: (oy - cy) / s, inside: inside};
  }

  let down = false;
  function send(kind, event) {
    const p = world(event);
    model.send({event: "pointer", kind: kind, x: p.x, y: p.y, inside: p.inside});
  }
  const onDown = (event) => {
    if (event.button !== 0 || model.get("disabled")) return;
    down = true;
    canvas.setPointerCapture(event.pointerId);
    root.focus({preventScroll: true});
    send("down", event);
    event.preventDefault();
  };
  const onMove = (event) => {
    if (down) send("move", event);
  };
  const onUp = (event) => {
    if (!down || event.button !== 0) return;
    down = false;
    send("up", event);
  };
  const onKey = (event) => {
    if (event.key === "c" && !model.get("disabled")) setMode(model.get("mode") === "cut" ? "drag" : "cut");
  };
  canvas.addEventListener("pointerdown", onDown);
  canvas.addEventListener("pointermove", onMove);
  canvas.addEventListener("pointerup", onUp);
  canvas.addEventListener("pointercancel", onUp);
  root.addEventListener("keydown", onKey);

  const handlers = [];
  function on(names, handler) {
    for (const name of names) {
      const event = `change:${name}`;
      model.on(event, handler);
      handlers.push([event, handler]);
    }
  }
  for (const name of ["positions", "triangles", "edges", "outline", "colors", "stroke"]) {
    on([name], () => {
      load(name);
      request();
    });
  }
  on(["target", "color_range", "dim"], request);
  on(["bounds"], () => {
    fit();
    request();
  });
  on(["width", "height"], () => {
    size();
    fit();
    request();
  });
  on(["mode"], showMode);
  on(["running", "disabled"], showRunning);
  on(["readout"], showReadout);
  on(["message"], () => {
    message.textContent = model.get("message");
  });

  size();
  fit();
  showMode();
  showRunning();
  message.textContent = model.get("message");
  request();
  return () => {
    for (const [event, handler] of handlers) model.off(event, handler);
  };
}

export default { render };
