// The browser side of tissuefem.surgery.widget.TissueWidget: draws a triangle mesh from binary arrays the kernel
// sends - on a 2D canvas (dim 2), or with WebGL as a lit surface seen by a camera the mouse turns (dim 3) - and sends
// the pointer back in world coordinates.
//
// Data model (the widget's traitlets):
//   dim          coordinates per point: 2 (the 2D canvas) or 3 (WebGL); changing it re-makes the view
//   positions    float32 bytes, (n_points, dim) row-major: sent every frame the tissue moved
//   triangles    int32 bytes, (n_triangles, 3): sent only when the topology changes (a cut); in 3D the surface
//   edges        int32 bytes, (n_edges, 2): the lines drawn over the faces, sent with the triangles
//   outline      int32 bytes: the boundary loops of point indices, each ended by -1; filled (nonzero rule) instead
//                of every triangle when there are no colours (far cheaper to rasterise without a GPU); 2D only
//   colors       float32 bytes, one value per triangle, or empty (one fill colour); mapped over color_range
//   bounds       [xmin, xmax, ymin, ymax] (3D: and zmin, zmax): the world box shown (2D: equal aspect, centred;
//                3D: the camera looks at its centre from far enough to see all of it)
//   target       [x, y] (3D: [x, y, z]) of the drag target, or []; stroke: float32 bytes (k, dim) of the cut stroke
//   readout, message, mode ("drag" or "cut"), width, height (CSS pixels)
//   running      whether the kernel's frame loop runs: the run button shows "pause" (running) or "run" (paused)
//   disabled     a view that stopped: the buttons and the pointer do nothing
// Pointer messages to the kernel: {event: "pointer", kind: "down" | "move" | "up", x, y, inside} (3D: and z).
// A picture is painted with requestAnimationFrame only when something new arrived: nothing runs at rest. What one
// message of the kernel brings (a frame: positions, target, ...) is one picture: pictures wait in a short queue and
// each animation frame paints the oldest, so two frames arriving between two animation frames are both painted (one
// animation frame apart) rather than the newer replacing the older. The canvas
// carries the paint count (data-painted) and, as canvas.tissuefem.log, the last paints' times, drag targets and
// milliseconds spent, for tests and benchmarks. 2D: the canvas (class tissuefem-canvas) carries the world-to-pixel
// map (data-view: [scale, ox, oy], CSS pixels of its content box: px = ox + scale * x, py = oy - scale * y).
// 3D: the canvas (class tissuefem-canvas3d) carries the positions received (data-received) and the camera
// (data-camera); canvas.tissuefem.project(x, y, z) gives a world point's CSS pixels in its content box and
// canvas.tissuefem.camera() the camera's eye and its forward, right and up directions (f, r, u).
// In 3D a left drag on the body grabs it at the surface point under the pointer (the nearest triangle the pointer's
// ray hits, at the positions shown) and moves that point in the plane through it facing the camera; a right drag, a
// shift+drag or a left drag beside the body turns the camera around the box's centre; the wheel zooms.

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
// pictures that may wait to be painted: the next animation frame's and a newer one
const QUEUED = 2;
function binRGB(k) {
  const t = (k + 0.5) / BINS; // 0..1
  const a = Math.abs(2 * t - 1);
  return t < 0.5 ? [255 - 200 * a, 255 - 140 * a, 255] : [255, 255 - 200 * a, 255 - 200 * a];
}

function binColor(k) {
  const [r, g, b] = binRGB(k);
  return `rgb(${r | 0},${g | 0},${b | 0})`;
}

function binOf(value, lo, hi) {
  return Math.max(0, Math.min(BINS - 1, Math.floor(((value - lo) / (hi - lo || 1)) * BINS)));
}

// What the 2D and the 3D view share: the buttons, the readout, the message line, the paint loop and its log, the
// key c and the traitlet handlers. `surface` is what sits between the buttons and the message (the canvas, or a
// box holding it); `paintBody` draws one picture and returns the drag target shown (or null).
function shell(model, el, canvas, surface) {
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
  canvas.dataset.painted = "0";
  const message = document.createElement("div");
  message.className = "tissuefem-message";
  message.style.cssText = "color:#b22222;min-height:1.3em;white-space:pre-wrap;";
  root.append(bar, surface, message);
  el.appendChild(root);

  // the pictures waiting to be painted (each what paintBody draws: the arrays and the target of one message)
  let painted = 0, scheduled = false, committing = false, queue = [], paintTimes = [];
  let paintBody = () => null, picture = () => null, shownText = null;
  const log = [];
  canvas.tissuefem = {log: log};

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
    run.title = running ? "pause the frames" : "run the frames (about 30 a second) while something changes";
    run.dataset.running = running ? "1" : "0";
    const off = model.get("disabled");
    for (const b of [run, ...Object.values(buttons)]) b.disabled = off;
    surface.style.opacity = off ? "0.6" : "1";
  }

  // something changed: once the message's changes are all in (a microtask later), its picture joins the queue
  function request() {
    if (!committing) {
      committing = true;
      queueMicrotask(commit);
    }
  }

  function commit() {
    committing = false;
    const next = picture(), last = queue[queue.length - 1];
    if (last && Object.keys(next).every((k) => next[k] === last[k])) queue[queue.length - 1] = next; // nothing new
    else queue.push(next);
    if (queue.length > QUEUED) queue.splice(0, queue.length - QUEUED); // the page falls behind: the oldest go
    if (!scheduled) {
      scheduled = true;
      requestAnimationFrame(paint);
    }
  }

  function paint() {
    scheduled = false;
    if (queue.length === 0) return;
    const started = performance.now();
    const target = paintBody(queue.shift());
    if (queue.length > 0) {
      scheduled = true;
      requestAnimationFrame(paint); // the next picture at the next animation frame
    }
    painted++;
    canvas.dataset.painted = String(painted);
    const now = performance.now();
    // the last paints, [time, target x, target y, ms] (3D: and target z), for a test or benchmark to time the pointer
    const shown = target && target.length >= 2;
    const entry = [now, shown ? target[0] : null, shown ? target[1] : null, now - started];
    if (shown && target.length >= 3) entry.push(target[2]);
    log.push(entry);
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
    const text = lines.join("\n");
    if (text !== shownText) readout.textContent = shownText = text; // the page lays out again only on a change
  }

  const onKey = (event) => {
    if (event.key === "c" && !model.get("disabled")) setMode(model.get("mode") === "cut" ? "drag" : "cut");
  };
  root.addEventListener("keydown", onKey);

  const handlers = [];
  function on(names, handler) {
    for (const name of names) {
      const event = `change:${name}`;
      model.on(event, handler);
      handlers.push([event, handler]);
    }
  }
  on(["mode"], showMode);
  on(["running", "disabled"], showRunning);
  on(["readout"], showReadout);
  on(["message"], () => {
    message.textContent = model.get("message");
  });

  // body(p) draws the picture p (what state() gave when it was queued) and returns the drag target it shows
  function start(body, state) {
    paintBody = body;
    picture = state;
    showMode();
    showRunning();
    message.textContent = model.get("message");
    request();
  }

  return {
    root, message, on, request, start,
    cleanup: () => {
      for (const [event, handler] of handlers) model.off(event, handler);
    },
  };
}

// ------------------------------------------------------------------ 2D: a canvas
function render2d({ model, el }) {
  const canvas = document.createElement("canvas");
  canvas.className = "tissuefem-canvas";
  canvas.style.cssText = "display:block;border:1px solid #ccc;touch-action:none;cursor:crosshair;";
  const view = shell(model, el, canvas, canvas);
  const root = view.root;
  const ctx = canvas.getContext("2d");

  const state = {positions: null, triangles: null, edges: null, outline: null, colors: null, stroke: null};
  let map = [1, 0, 0];

  function load(name) {
    const v = model.get(name);
    if (name === "triangles" || name === "edges" || name === "outline") state[name] = ints(v);
    else state[name] = floats(v);
  }
  for (const name of ["positions", "triangles", "edges", "outline", "colors", "stroke"]) load(name);

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

  // what one picture shows: the arrays as they arrived with it, and the target
  const picture = () => ({...state, target: model.get("target")});

  function paint(p) {
    const w = model.get("width"), h = model.get("height");
    const [s, ox, oy] = map;
    const dim = model.get("dim") || 2;
    const x = p.positions, t = p.triangles, e = p.edges, c = p.colors;
    ctx.clearRect(0, 0, w, h);
    const n = x ? x.length / dim : 0;
    if (n > 0 && t.length > 0) {
      const px = (i) => ox + s * x[dim * i];
      const py = (i) => oy - s * x[dim * i + 1];
      const nt = t.length / 3;
      const colored = c && c.length === nt;
      const [lo, hi] = model.get("color_range");
      const o = p.outline;
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
        const path = paths[colored ? binOf(c[k], lo, hi) : 0];
        path.moveTo(px(a), py(a));
        path.lineTo(px(b), py(b));
        path.lineTo(px(d), py(d));
      }
      paths.forEach((path, k) => {
        ctx.fillStyle = colored ? binColor(k) : FILL;
        ctx.fill(path);
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
    const st = p.stroke;
    if (st && st.length >= 2) {
      ctx.beginPath();
      ctx.moveTo(ox + s * st[0], oy - s * st[1]);
      for (let k = 2; k < st.length; k += 2) ctx.lineTo(ox + s * st[k], oy - s * st[k + 1]);
      ctx.strokeStyle = "#000";
      ctx.lineWidth = 1.5;
      ctx.stroke();
    }
    const target = p.target;
    if (target && target.length >= 2) {
      ctx.beginPath();
      ctx.arc(ox + s * target[0], oy - s * target[1], 5, 0, 2 * Math.PI);
      ctx.strokeStyle = TARGET;
      ctx.lineWidth = 2;
      ctx.stroke();
    }
    return target;
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
  canvas.addEventListener("pointerdown", onDown);
  canvas.addEventListener("pointermove", onMove);
  canvas.addEventListener("pointerup", onUp);
  canvas.addEventListener("pointercancel", onUp);

  const { on, request } = view;
  for (const name of ["positions", "triangles", "edges", "outline", "colors", "stroke"]) {
    on([name], () => {
      load(name);
      request();
    });
  }
  on(["target", "color_range"], request);
  on(["bounds"], () => {
    fit();
    request();
  });
  on(["width", "height"], () => {
    size();
    fit();
    request();
  });

  size();
  fit();
  view.start(paint, picture);
  return view.cleanup;
}

// ------------------------------------------------------------------ 3D: WebGL
// small vector and matrix helpers (3-vectors as arrays; 4x4 matrices column-major, as WebGL takes them)
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const along = (a, s, b) => [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]];
function unit(a) {
  const l = Math.hypot(a[0], a[1], a[2]);
  return l > 0 ? [a[0] / l, a[1] / l, a[2] / l] : [0, 0, 1];
}

const VERTEX_SHADER = `
attribute vec3 a_position;
attribute vec3 a_normal;
attribute vec3 a_color;
uniform mat4 u_matrix;
uniform vec3 u_light;
uniform float u_flat;
varying vec3 v_color;
void main() {
  gl_Position = u_matrix * vec4(a_position, 1.0);
  float lambert = abs(dot(a_normal, u_light));
  v_color = mix(a_color * (0.5 + 0.5 * lambert), a_color, u_flat);
}`;

const FRAGMENT_SHADER = `
precision mediump float;
varying vec3 v_color;
void main() {
  gl_FragColor = vec4(v_color, 1.0);
}`;

function program(gl) {
  const compile = (type, source) => {
    const s = gl.createShader(type);
    gl.shaderSource(s, source);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
    return s;
  };
  const p = gl.createProgram();
  gl.attachShader(p, compile(gl.VERTEX_SHADER, VERTEX_SHADER));
  gl.attachShader(p, compile(gl.FRAGMENT_SHADER, FRAGMENT_SHADER));
  gl.linkProgram(p);
  if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
  return p;
}

function hexRGB(hex) {
  return [1, 3, 5].map((i) => parseInt(hex.slice(i, i + 2), 16) / 255);
}

// A camera turning around the centre of a box: yaw about the y axis, pitch above the x-z plane, at a distance.
// frame(w, h) gives its eye, forward f, right r and up u and the half-widths tx, ty of the view at unit distance:
// the pixel at CSS (cx, cy) of a w x h picture looks along f + (2 cx / w - 1) tx r + (1 - 2 cy / h) ty u.
class Orbit {
  constructor() {
    this.yaw = 0.5;
    this.pitch = 0.4;
    this.distance = 1;
    this.radius = 1;
    this.centre = [0, 0, 0];
    this.fov = 35 * Math.PI / 180; // vertical
  }

  fit(b) {
    // [xmin, xmax, ymin, ymax, zmin, zmax]: its bounding sphere nearly fills the picture (the box has margins)
    const lo = [b[0], b[2], b.length >= 6 ? b[4] : 0], hi = [b[1], b[3], b.length >= 6 ? b[5] : 0];
    this.centre = lo.map((v, i) => 0.5 * (v + hi[i]));
    this.radius = 0.5 * Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) || 1;
    this.distance = 0.8 * this.radius / Math.sin(this.fov / 2);
  }

  turn(yaw, pitch) {
    this.yaw = yaw;
    this.pitch = Math.max(-1.5, Math.min(1.5, pitch));
  }

  zoom(factor) {
    this.distance = Math.max(0.3 * this.radius, Math.min(30 * this.radius, this.distance * factor));
  }

  describe() {
    return {yaw: this.yaw, pitch: this.pitch, distance: this.distance};
  }

  frame(w, h) {
    const {yaw, pitch, distance, centre} = this;
    const eye = along(centre, distance, [Math.cos(pitch) * Math.sin(yaw), Math.sin(pitch),
      Math.cos(pitch) * Math.cos(yaw)]);
    const f = unit(sub(centre, eye)), r = unit(cross(f, [0, 1, 0])), u = cross(r, f);
    const ty = Math.tan(this.fov / 2), tx = ty * w / h;
    return {eye, f, r, u, tx, ty, w, h};
  }

  matrix(c) {
    // perspective times the view, column-major, for the frame c
    const near = Math.max(1e-3 * this.distance, this.distance - 3 * this.radius);
    const far = this.distance + 3 * this.radius;
    const {eye, f, r, u, tx, ty} = c;
    const a = (far + near) / (near - far), b = (2 * far * near) / (near - far);
    const rows = [[r[0] / tx, r[1] / tx, r[2] / tx, -dot(r, eye) / tx],
      [u[0] / ty, u[1] / ty, u[2] / ty, -dot(u, eye) / ty],
      [-a * f[0], -a * f[1], -a * f[2], a * dot(f, eye) + b],
      [f[0], f[1], f[2], -dot(f, eye)]];
    const m = new Float32Array(16);
    for (let i = 0; i < 4; i++) for (let j = 0; j < 4; j++) m[4 * j + i] = rows[i][j];
    return m;
  }
}

// a world point's CSS pixels in the frame c
function project(p, c) {
  const d = sub(p, c.eye), z = dot(d, c.f);
  return [c.w / 2 * (1 + dot(d, c.r) / (z * c.tx)), c.h / 2 * (1 - dot(d, c.u) / (z * c.ty))];
}

// the ray of the pixel at CSS (cx, cy) in the frame c
function ray(c, cx, cy) {
  const sx = (2 * cx / c.w - 1) * c.tx, sy = (1 - 2 * cy / c.h) * c.ty;
  return {origin: c.eye, direction: along(along(c.f, sx, c.r), sy, c.u)};
}

// the nearest point where the ray meets a triangle (Moller-Trumbore on every one; points x: float32 (n, 3)), or null
function pick(x, t, line) {
  const n = x ? x.length / 3 : 0, point = (i) => [x[3 * i], x[3 * i + 1], x[3 * i + 2]];
  let best = Infinity;
  for (let k = 0; k < t.length; k += 3) {
    if (t[k] >= n || t[k + 1] >= n || t[k + 2] >= n) continue;
    const a = point(t[k]), e1 = sub(point(t[k + 1]), a), e2 = sub(point(t[k + 2]), a);
    const p = cross(line.direction, e2), det = dot(e1, p);
    if (Math.abs(det) < 1e-14) continue;
    const s = sub(line.origin, a), u = dot(s, p) / det;
    if (u < 0 || u > 1) continue;
    const q = cross(s, e1), v = dot(line.direction, q) / det;
    if (v < 0 || u + v > 1) continue;
    const distance = dot(e2, q) / det;
    if (distance > 0 && distance < best) best = distance;
  }
  return best < Infinity ? along(line.origin, best, line.direction) : null;
}

// The surface drawn with WebGL: faces flat-shaded (one vertex per corner, with the face's normal and colour) and
// lit from near the camera on both sides, their edges drawn over them. The colours are computed again when a
// picture brings other triangles or colours than the last coloured one, and after recolor() (a new colour range);
// draw(...) each picture.
function surfacePainter(gl) {
  const prog = program(gl);
  const loc = {position: gl.getAttribLocation(prog, "a_position"), normal: gl.getAttribLocation(prog, "a_normal"),
    color: gl.getAttribLocation(prog, "a_color"), matrix: gl.getUniformLocation(prog, "u_matrix"),
    light: gl.getUniformLocation(prog, "u_light"), flat: gl.getUniformLocation(prog, "u_flat")};
  const buffers = {position: gl.createBuffer(), normal: gl.createBuffer(), color: gl.createBuffer(),
    edges: gl.createBuffer()};
  let P = new Float32Array(0), N = new Float32Array(0), E = new Float32Array(0), stale = true;
  let coloured = [null, null]; // the triangles and colours the colour buffer was made from

  function colour(nt, c, range) {
    const colored = c && c.length === nt, [lo, hi] = range;
    const fill = hexRGB(FILL), rgb = new Float32Array(9 * nt);
    const table = Array.from({length: BINS}, (_, k) => binRGB(k).map((v) => v / 255));
    for (let k = 0; k < nt; k++) {
      const col = colored ? table[binOf(c[k], lo, hi)] : fill;
      for (let j = 0; j < 3; j++) rgb.set(col, 9 * k + 3 * j);
    }
    gl.bindBuffer(gl.ARRAY_BUFFER, buffers.color);
    gl.bufferData(gl.ARRAY_BUFFER, rgb, gl.STATIC_DRAW);
    stale = false;
  }

  function corners(x, t, e) {
    const nt = t.length / 3, n = x.length / 3, point = (i) => [x[3 * i], x[3 * i + 1], x[3 * i + 2]];
    if (P.length !== 9 * nt) [P, N] = [new Float32Array(9 * nt), new Float32Array(9 * nt)];
    if (E.length !== 3 * e.length) E = new Float32Array(3 * e.length);
    for (let k = 0; k < nt; k++) {
      const a = t[3 * k], b = t[3 * k + 1], d = t[3 * k + 2];
      if (a >= n || b >= n || d >= n) { // a frame between new triangles and their positions: not drawn
        P.fill(0, 9 * k, 9 * k + 9);
        continue;
      }
      const pa = point(a), pb = point(b), pd = point(d), normal = unit(cross(sub(pb, pa), sub(pd, pa)));
      P.set(pa, 9 * k);
      P.set(pb, 9 * k + 3);
      P.set(pd, 9 * k + 6);
      for (let j = 0; j < 3; j++) N.set(normal, 9 * k + 3 * j);
    }
    for (let k = 0; k < e.length; k += 2) {
      if (e[k] >= n || e[k + 1] >= n) E.fill(0, 3 * k, 3 * k + 6);
      else {
        E.set(point(e[k]), 3 * k);
        E.set(point(e[k + 1]), 3 * k + 3);
      }
    }
  }

  function attribute(location, buffer, data) {
    gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
    if (data) gl.bufferData(gl.ARRAY_BUFFER, data, gl.DYNAMIC_DRAW);
    gl.enableVertexAttribArray(location);
    gl.vertexAttribPointer(location, 3, gl.FLOAT, false, 0, 0);
  }

  function draw(x, t, e, c, range, matrix, light) {
    gl.viewport(0, 0, gl.canvas.width, gl.canvas.height);
    gl.clearColor(1, 1, 1, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    if (!x || x.length < 3 || t.length === 0) return;
    if (stale || coloured[0] !== t || coloured[1] !== c) {
      colour(t.length / 3, c, range);
      coloured = [t, c];
    }
    corners(x, t, e);
    gl.useProgram(prog);
    gl.uniformMatrix4fv(loc.matrix, false, matrix);
    gl.uniform3fv(loc.light, light);
    attribute(loc.position, buffers.position, P);
    attribute(loc.normal, buffers.normal, N);
    attribute(loc.color, buffers.color, null);
    gl.uniform1f(loc.flat, 0);
    gl.enable(gl.POLYGON_OFFSET_FILL); // the edges drawn after the faces stay in front of them
    gl.polygonOffset(1, 1);
    gl.drawArrays(gl.TRIANGLES, 0, t.length);
    gl.disable(gl.POLYGON_OFFSET_FILL);
    if (E.length > 0) {
      attribute(loc.position, buffers.edges, E);
      gl.disableVertexAttribArray(loc.normal);
      gl.disableVertexAttribArray(loc.color);
      gl.vertexAttrib3f(loc.normal, 0, 0, 1);
      gl.vertexAttrib3fv(loc.color, hexRGB(EDGE));
      gl.uniform1f(loc.flat, 1);
      gl.drawArrays(gl.LINES, 0, E.length / 3);
    }
  }

  return {draw, recolor: () => { stale = true; }};
}

// the cut stroke (float32 (k, 3)) and the drag target ([x, y, z] or []), projected, on the 2D context over the picture
function drawTools(ctx, c, stroke, target) {
  ctx.clearRect(0, 0, c.w, c.h);
  if (stroke && stroke.length >= 6) {
    ctx.beginPath();
    for (let k = 0; k + 2 < stroke.length; k += 3) {
      const [px, py] = project([stroke[k], stroke[k + 1], stroke[k + 2]], c);
      if (k === 0) ctx.moveTo(px, py);
      else ctx.lineTo(px, py);
    }
    ctx.strokeStyle = "#000";
    ctx.lineWidth = 1.5;
    ctx.stroke();
  }
  if (target && target.length >= 3) {
    const [px, py] = project(target, c);
    ctx.beginPath();
    ctx.arc(px, py, 5, 0, 2 * Math.PI);
    ctx.strokeStyle = TARGET;
    ctx.lineWidth = 2;
    ctx.stroke();
  }
}

function render3d({ model, el }) {
  const box = document.createElement("div");
  box.style.cssText = "position:relative;line-height:0;";
  const canvas = document.createElement("canvas");
  canvas.className = "tissuefem-canvas3d";
  canvas.style.cssText = "display:block;border:1px solid #ccc;touch-action:none;cursor:grab;";
  const overlay = document.createElement("canvas"); // the drag target and the stroke, over the picture
  overlay.style.cssText = "position:absolute;left:1px;top:1px;pointer-events:none;";
  box.append(canvas, overlay);
  const view = shell(model, el, canvas, box);
  const ctx = overlay.getContext("2d");
  const gl = canvas.getContext("webgl", {antialias: true});
  if (!gl) {
    view.message.textContent = "this browser offers no WebGL: the 3D view cannot draw here (snapshot(view) " +
      "draws it as a static figure)";
    return view.cleanup;
  }
  const painter = surfacePainter(gl), camera = new Orbit();
  const state = {positions: null, triangles: null, edges: null, colors: null, stroke: null};
  let received = 0;
  const frame = () => camera.frame(model.get("width"), model.get("height"));
  canvas.tissuefem.project = (x, y, z) => project([x, y, z], frame());
  canvas.tissuefem.camera = frame;

  function load(name) {
    const v = model.get(name);
    state[name] = name === "triangles" || name === "edges" ? ints(v) : floats(v);
    if (name === "positions") canvas.dataset.received = String(++received);
  }
  for (const name of ["positions", "triangles", "edges", "colors", "stroke"]) load(name);

  function size() {
    const w = model.get("width"), h = model.get("height"), dpr = window.devicePixelRatio || 1;
    for (const c of [canvas, overlay]) {
      c.style.width = `${w}px`;
      c.style.height = `${h}px`;
      c.width = Math.round(w * dpr);
      c.height = Math.round(h * dpr);
    }
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  }

  function moved() {
    canvas.dataset.camera = JSON.stringify(camera.describe());
    view.request();
  }

  // what one picture shows: the arrays as they arrived with it, and the target (the camera: as it is when painted)
  const picture = () => ({...state, target: model.get("target")});

  function paint(p) {
    const c = frame(), light = unit(along(along(c.f, -0.5, c.u), 0.3, c.r)); // from the camera, above, left
    painter.draw(p.positions, p.triangles, p.edges, p.colors, model.get("color_range"), camera.matrix(c), light);
    drawTools(ctx, c, p.stroke, p.target);
    return p.target;
  }

  // the pointer: grab (a left press on the body) or turn the camera (right, shift+left, or left beside the body)
  let gesture = null;
  function pointer(event, c) {
    const rect = canvas.getBoundingClientRect();
    const cx = event.clientX - rect.left - canvas.clientLeft, cy = event.clientY - rect.top - canvas.clientTop;
    const inside = cx >= 0 && cy >= 0 && cx <= canvas.clientWidth && cy <= canvas.clientHeight;
    return {...ray(c, cx, cy), inside};
  }
  function inPlane(event, g) {
    // where the pointer's ray meets the plane through the grabbed point facing the camera (as it was at the press)
    const r = pointer(event, g.frame), s = dot(sub(g.point, r.origin), g.frame.f) / dot(r.direction, g.frame.f);
    return {point: along(r.origin, s, r.direction), inside: r.inside};
  }
  function send(kind, p, inside) {
    model.send({event: "pointer", kind: kind, x: p[0], y: p[1], z: p[2], inside: inside});
  }
  const onDown = (event) => {
    if (event.button !== 0 && event.button !== 2) return;
    canvas.setPointerCapture(event.pointerId);
    view.root.focus({preventScroll: true});
    event.preventDefault();
    const c = frame(), grab = event.button === 0 && !event.shiftKey && !model.get("disabled");
    const hit = grab ? pick(state.positions, state.triangles, pointer(event, c)) : null;
    gesture = hit ? {kind: "grab", button: event.button, point: hit, frame: c}
      : {kind: "turn", button: event.button, x: event.clientX, y: event.clientY, yaw: camera.yaw, pitch: camera.pitch};
    if (hit) send("down", hit, true);
  };
  const onMove = (event) => {
    if (!gesture) return;
    if (gesture.kind === "grab") send("move", inPlane(event, gesture).point, true);
    else {
      camera.turn(gesture.yaw - 0.01 * (event.clientX - gesture.x), gesture.pitch + 0.01 * (event.clientY - gesture.y));
      moved();
    }
  };
  const onUp = (event) => {
    if (!gesture || event.button !== gesture.button) return;
    const g = gesture;
    gesture = null;
    if (g.kind === "grab") {
      const p = inPlane(event, g);
      send("up", p.point, p.inside);
    }
  };
  canvas.addEventListener("pointerdown", onDown);
  canvas.addEventListener("pointermove", onMove);
  canvas.addEventListener("pointerup", onUp);
  canvas.addEventListener("pointercancel", onUp);
  canvas.addEventListener("contextmenu", (event) => event.preventDefault());
  canvas.addEventListener("wheel", (event) => {
    event.preventDefault();
    camera.zoom(Math.exp(0.001 * event.deltaY));
    moved();
  }, {passive: false});

  const { on, request } = view;
  for (const name of ["positions", "triangles", "edges", "colors", "stroke"]) {
    on([name], () => {
      load(name);
      request();
    });
  }
  on(["target"], request);
  on(["color_range"], () => {
    painter.recolor();
    request();
  });
  on(["bounds"], () => {
    camera.fit(model.get("bounds"));
    moved();
  });
  on(["width", "height"], () => {
    size();
    request();
  });

  size();
  camera.fit(model.get("bounds"));
  canvas.dataset.camera = JSON.stringify(camera.describe());
  view.start(paint, picture);
  return view.cleanup;
}

// ------------------------------------------------------------------ the widget: 2D or 3D, by dim
function render({ model, el }) {
  let current = null, cleanup = null;
  function mount() {
    const dim = model.get("dim") === 3 ? 3 : 2;
    if (dim === current) return;
    if (cleanup) cleanup();
    el.replaceChildren();
    current = dim;
    cleanup = (dim === 3 ? render3d : render2d)({model, el});
  }
  model.on("change:dim", mount);
  mount();
  return () => {
    model.off("change:dim", mount);
    if (cleanup) cleanup();
  };
}

export default { render };
