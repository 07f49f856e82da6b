// shellvox view: slices of a build along z, y and x, drawn at the voxels' true size.
// Plain JavaScript and a 2D canvas; everything comes from this server (no libraries).
//
// A slice is a plane with a horizontal axis u and a vertical axis v (mm, v upwards):
// z slice: u = x, v = y; y slice: u = x, v = z; x slice: u = y, v = z. The server returns
// a region of it as rows (v index) and columns (u index), row 0 the lowest index, with a
// step: the number of voxels one screen pixel covers, so a zoomed-out view of a large
// build reads a fraction of its pages.
"use strict";

(() => {
  const PLANE = { z: { u: "x", v: "y" }, y: { u: "x", v: "z" }, x: { u: "y", v: "z" } };
  const XYZ = { x: 0, y: 1, z: 2 }; // position in origin_mm / voxel_mm
  const ZYX = { z: 0, y: 1, x: 2 }; // position in shape_zyx
  const MODES = ["colour", "layers", "blend", "materials", "depth", "thickness"];
  const NEEDS = {
    colour: ["layers", "colour"],
    layers: ["layers"],
    blend: ["layers", "colour"],
    materials: ["materials"],
    depth: ["layers", "depth"],
    thickness: ["layers", "depth"],
  };
  // the layer tones of voxel/preview.py: outside, bands (cycled), core
  const OUTSIDE = [255, 255, 255];
  const BANDS = [[120, 120, 120], [170, 150, 110], [110, 150, 170], [150, 110, 170]];
  const CORE = [60, 60, 60];
  const BACKGROUND = "#e9e9e9";
  // a perceptually ordered ramp (viridis stops) for depth and thickness
  const RAMP = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];

  const canvas = document.getElementById("view");
  const ctx = canvas.getContext("2d");
  const slider = document.getElementById("slice");
  const number = document.getElementById("slice-number");
  const body = document.body;

  const state = {
    build: null,
    axis: "z",
    index: { z: 0, y: 0, x: 0 },
    mode: "colour",
    scale: 1, // CSS pixels per mm
    cx: 0, // mm at the canvas centre (u, v)
    cy: 0,
    image: null, // the last slice drawn: {axis, index, mode, region, bitmap, ...}
    probe: null,
    pending: false,
    busy: false,
    palette: null,
    colourLayer: null,
    materialRgb: null,
    depthMax: 1,
    thicknessRange: [0, 1],
    moved: false, // the slice or axis was changed by hand (then the opening slice waits)
  };

  // ---- geometry ----
  function plane(axis) {
    const g = state.build.grid;
    const { u, v } = PLANE[axis];
    return {
      u, v,
      nu: g.shape_zyx[ZYX[u]], nv: g.shape_zyx[ZYX[v]],
      su: g.voxel_mm[XYZ[u]], sv: g.voxel_mm[XYZ[v]],
      ou: g.origin_mm[XYZ[u]], ov: g.origin_mm[XYZ[v]],
    };
  }
  const size = () => ({ w: canvas.clientWidth, h: canvas.clientHeight });
  const toScreen = (u, v) => {
    const { w, h } = size();
    return [w / 2 + (u - state.cx) * state.scale, h / 2 - (v - state.cy) * state.scale];
  };
  const toPlane = (sx, sy) => {
    const { w, h } = size();
    return [state.cx + (sx - w / 2) / state.scale, state.cy - (sy - h / 2) / state.scale];
  };

  function fit() {
    const p = plane(state.axis);
    const { w, h } = size();
    const widthMm = p.nu * p.su;
    const heightMm = p.nv * p.sv;
    state.scale = 0.95 * Math.min(w / widthMm, h / heightMm);
    state.cx = p.ou + (p.nu - 1) * p.su / 2;
    state.cy = p.ov + (p.nv - 1) * p.sv / 2;
  }

  function wantedRegion() {
    const p = plane(state.axis);
    const { w, h } = size();
    const dpr = window.devicePixelRatio || 1;
    const [u0, v1] = toPlane(0, 0);
    const [u1, v0] = toPlane(w, h);
    // voxels per device pixel, to a power of two: the pages of one step are among those
    // of the next finer one, so pages the server decoded before serve again
    const step = (s) => 2 ** Math.max(0, Math.round(Math.log2(1 / (state.scale * dpr * s))));
    const cs = step(p.su);
    const rs = step(p.sv);
    const span = (lo, hi, o, s, n, step) => {
      let a = Math.max(0, Math.floor((lo - o) / s - 0.5));
      const b = Math.min(n, Math.ceil((hi - o) / s + 0.5) + 1);
      a = Math.floor(a / step) * step;
      return [a, Math.max(a, b)];
    };
    const [c0, c1] = span(u0, u1, p.ou, p.su, p.nu, cs);
    const [r0, r1] = span(v0, v1, p.ov, p.sv, p.nv, rs);
    return { r0, r1, rs, c0, c1, cs };
  }

  // ---- palettes ----
  function preparePalettes() {
    const b = state.build;
    const n = b.layers.length;
    state.palette = [];
    state.colourLayer = new Uint8Array(256);
    for (let i = 0; i < 256; i++) {
      if (i === 0) state.palette.push(OUTSIDE);
      else if (i === n - 1) state.palette.push(CORE);
      else if (i < n - 1) state.palette.push(BANDS[(i - 1) % BANDS.length]);
      else state.palette.push([255, 0, 255]);
    }
    for (const layer of b.layers) if (layer.colour) state.colourLayer[layer.index] = 1;
    state.materialRgb = [];
    for (let i = 0; i < 256; i++) state.materialRgb.push([255, 0, 255]);
    for (const m of b.materials) state.materialRgb[m.index] = m.display_srgb;
    state.materialRgb[0] = OUTSIDE;
    state.depthMax = b.depth_range_mm[1];
    state.thicknessRange = b.thickness_range_mm;
  }

  function ramp(t) {
    if (!(t >= 0)) t = 0;
    if (t > 1) t = 1;
    const x = t * (RAMP.length - 1);
    const i = Math.min(RAMP.length - 2, Math.floor(x));
    const f = x - i;
    return RAMP[i].map((c, k) => Math.round(c + (RAMP[i + 1][k] - c) * f));
  }

  // ---- composing a slice image from the arrays of its mode ----
  function compose(mode, arrays) {
    const first = arrays[NEEDS[mode][0]];
    const [h, w] = first.shape;
    const image = new ImageData(w, h);
    const out = image.data;
    const layers = arrays.layers ? arrays.layers.array : null;
    const colour = arrays.colour ? arrays.colour.array : null;
    const cs = arrays.colour ? arrays.colour.shape[2] : 0;
    const depth = arrays.depth ? arrays.depth.array : null;
    const pal = state.palette;
    for (let r = 0; r < h; r++) {
      const target = (h - 1 - r) * w; // row 0 is the lowest index: drawn at the bottom
      for (let c = 0; c < w; c++) {
        const i = r * w + c;
        let rgb;
        if (mode === "materials") {
          rgb = state.materialRgb[arrays.materials.array[i]];
        } else {
          const layer = layers[i];
          rgb = pal[layer];
          if ((mode === "colour" || mode === "blend") && state.colourLayer[layer]) {
            const k = i * cs;
            if (mode === "colour") rgb = [colour[k], colour[k + 1], colour[k + 2]];
            else rgb = [0, 1, 2].map((j) => Math.round(0.6 * colour[k + j] + 0.4 * rgb[j]));
          } else if (mode === "colour" && layer !== 0) {
            rgb = rgb.map((x) => Math.round(x + (255 - x) * 0.55)); // inner layers faded
          } else if (mode === "depth" || mode === "thickness") {
            const value = depth[2 * i + (mode === "depth" ? 0 : 1)];
            if (!Number.isNaN(value)) {
              const [lo, hi] = mode === "depth" ? [0, state.depthMax] : state.thicknessRange;
              rgb = ramp((value - lo) / (hi - lo));
            }
          }
        }
        const o = 4 * (target + c);
        out[o] = rgb[0];
        out[o + 1] = rgb[1];
        out[o + 2] = rgb[2];
        out[o + 3] = 255;
      }
    }
    const bitmap = document.createElement("canvas");
    bitmap.width = w;
    bitmap.height = h;
    bitmap.getContext("2d").putImageData(image, 0, 0);
    return bitmap;
  }

  // ---- loading ----
  async function fetchKind(kind, view, signal) {
    const query = new URLSearchParams({ kind, axis: view.axis, index: view.index });
    for (const [key, value] of Object.entries(view.region)) query.set(key, value);
    const response = await fetch("/api/slice?" + query, { signal });
    if (!response.ok) throw new Error(`${kind}: ${await response.text()}`);
    const shape = response.headers.get("X-Shape").split(",").map(Number);
    const dtype = response.headers.get("X-Dtype");
    const buffer = await response.arrayBuffer();
    const array = dtype === "float32" ? new Float32Array(buffer) : new Uint8Array(buffer);
    return { shape, array, seconds: Number(response.headers.get("X-Seconds")) };
  }

  function sameView(a, b) {
    return a && b && a.axis === b.axis && a.index === b.index && a.mode === b.mode
      && a.region.rs === b.region.rs && a.region.cs === b.region.cs
      && a.region.r0 <= b.region.r0 && a.region.r1 >= b.region.r1
      && a.region.c0 <= b.region.c0 && a.region.c1 >= b.region.c1;
  }

  function requestLoad() {
    state.pending = true;
    if (!state.busy) loadLoop();
  }

  async function loadLoop() {
    state.busy = true;
    let failed = false;
    while (state.pending) {
      state.pending = false;
      const view = {
        axis: state.axis, index: state.index[state.axis], mode: state.mode, region: wantedRegion(),
      };
      if (sameView(state.image, view)) continue;
      body.dataset.status = "loading";
      const started = performance.now();
      try {
        const kinds = NEEDS[view.mode];
        const results = await Promise.all(kinds.map((k) => fetchKind(k, view, undefined)));
        const arrays = Object.fromEntries(kinds.map((k, i) => [k, results[i]]));
        const [h, w] = results[0].shape;
        state.image = {
          ...view, w, h, bitmap: compose(view.mode, arrays),
          serverMs: 1000 * Math.max(...results.map((r) => r.seconds)),
          totalMs: performance.now() - started,
        };
        showError("");
        failed = false;
      } catch (error) {
        showError(String(error.message || error));
        failed = true;
        continue;
      }
      draw();
      showStatus();
    }
    state.busy = false;
    const image = state.image;
    if (image) body.dataset.view = `${image.axis}:${image.index}:${image.mode}`;
    body.dataset.status = failed ? "error" : "ready";
  }

  // ---- drawing ----
  function draw() {
    const dpr = window.devicePixelRatio || 1;
    const { w, h } = size();
    if (canvas.width !== Math.round(w * dpr) || canvas.height !== Math.round(h * dpr)) {
      canvas.width = Math.round(w * dpr);
      canvas.height = Math.round(h * dpr);
    }
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.fillStyle = BACKGROUND;
    ctx.fillRect(0, 0, w, h);
    if (!state.build) return;
    const p = plane(state.axis);
    const image = state.image;
    if (image && image.axis === state.axis) {
      const { r0, rs, c0, cs } = image.region;
      const [left, top] = toScreen(p.ou + (c0 - 0.5) * p.su, p.ov + (r0 + image.h * rs - 0.5) * p.sv);
      const [right, bottom] = toScreen(p.ou + (c0 + image.w * cs - 0.5) * p.su, p.ov + (r0 - 0.5) * p.sv);
      ctx.imageSmoothingEnabled = false;
      ctx.drawImage(image.bitmap, left, top, right - left, bottom - top);
    }
    // the grid's outline
    const [gl, gt] = toScreen(p.ou - 0.5 * p.su, p.ov + (p.nv - 0.5) * p.sv);
    const [gr, gb] = toScreen(p.ou + (p.nu - 0.5) * p.su, p.ov - 0.5 * p.sv);
    ctx.strokeStyle = "#999";
    ctx.lineWidth = 1;
    ctx.strokeRect(gl, gt, gr - gl, gb - gt);
    drawProbe(p);
    drawScaleBar(w, h);
  }

  function drawProbe(p) {
    const probe = state.probe;
    if (!probe) return;
    const [z, y, x] = probe.index_zyx;
    const index = { z, y, x };
    if (index[state.axis] !== state.index[state.axis]) return;
    const iu = index[p.u];
    const iv = index[p.v];
    const [l, t] = toScreen(p.ou + (iu - 0.5) * p.su, p.ov + (iv + 0.5) * p.sv);
    const [r, b] = toScreen(p.ou + (iu + 0.5) * p.su, p.ov + (iv - 0.5) * p.sv);
    const pad = Math.max(0, 6 - (r - l) / 2);
    ctx.strokeStyle = "#e00";
    ctx.lineWidth = 2;
    ctx.strokeRect(l - pad, t - pad, r - l + 2 * pad, b - t + 2 * pad);
  }

  function drawScaleBar(w, h) {
    const target = 120 / state.scale; // mm in about 120 px
    const power = Math.pow(10, Math.floor(Math.log10(target)));
    const mm = [1, 2, 5, 10].map((m) => m * power).filter((m) => m <= target).pop();
    const length = mm * state.scale;
    ctx.fillStyle = "#222";
    ctx.fillRect(12, h - 18, length, 3);
    ctx.font = "12px system-ui, sans-serif";
    ctx.fillText(`${+mm.toPrecision(3)} mm`, 12, h - 24);
  }

  // ---- read-out ----
  const cell = (id) => document.getElementById(id);
  function setCell(id, text, value) {
    const element = cell(id);
    element.textContent = text;
    if (value === undefined || value === null) delete element.dataset.value;
    else element.dataset.value = typeof value === "string" ? value : JSON.stringify(value);
  }

  async function probeAt(sx, sy) {
    const p = plane(state.axis);
    const [u, v] = toPlane(sx, sy);
    const iu = Math.round((u - p.ou) / p.su);
    const iv = Math.round((v - p.ov) / p.sv);
    if (iu < 0 || iu >= p.nu || iv < 0 || iv >= p.nv) return;
    const index = { [state.axis]: state.index[state.axis], [p.u]: iu, [p.v]: iv };
    body.dataset.probe = "loading";
    const query = new URLSearchParams({ z: index.z, y: index.y, x: index.x });
    const response = await fetch("/api/voxel?" + query);
    if (!response.ok) {
      showError(await response.text());
      body.dataset.probe = "error";
      return;
    }
    state.probe = await response.json();
    showProbe(state.probe);
    draw();
    body.dataset.probe = state.probe.index_zyx.join(",");
  }

  function showProbe(probe) {
    const fixed = (values, digits) => values.map((v) => v.toFixed(digits)).join(", ");
    setCell("ro-index", probe.index_zyx.join(", "), probe.index_zyx);
    setCell("ro-position", fixed(probe.position_mm, 3) + " mm", probe.position_mm);
    setCell("ro-layer", `${probe.layer.index} ${probe.layer.name}`, probe.layer.index);
    const c = probe.colour;
    if (c) {
      const alpha = c.alpha === null ? "" : `, alpha ${c.alpha}`;
      setCell("ro-srgb", `${c.srgb.join(", ")}${alpha}`, c.srgb);
      const swatch = document.createElement("span");
      swatch.className = "swatch";
      swatch.style.background = `rgb(${c.srgb.join(",")})`;
      cell("ro-srgb").prepend(swatch);
      const [L, a, b] = c.lab;
      setCell("ro-lab", `L* ${L.toFixed(2)}  a* ${a.toFixed(2)}  b* ${b.toFixed(2)}`, c.lab);
    } else {
      setCell("ro-srgb", "none (not a colour layer)", null);
      setCell("ro-lab", "", null);
    }
    const m = probe.material;
    setCell("ro-material", m ? `${m.index} ${m.name}` : "no materials.tif", m ? m.index : null);
    const d = probe.depth;
    if (d) {
      const where = d.inside ? "below the surface" : "outside the surface";
      setCell("ro-depth", `${d.mm.toFixed(4)} mm ${where}`, d.mm);
      const limits = d.layer_limits_mm.map((x) => x.toFixed(3)).join(", ");
      setCell("ro-thickness", `colour layer ${d.colour_layer_mm.toFixed(3)} mm; layer limits ${limits} mm (face ${d.face})`,
        d.colour_layer_mm);
    } else {
      setCell("ro-depth", "no thickness.ply in this build", null);
      setCell("ro-thickness", "", null);
    }
  }

  // ---- legend and status ----
  function swatchRow(rgb, text) {
    const row = document.createElement("div");
    const swatch = document.createElement("span");
    swatch.className = "swatch";
    swatch.style.background = `rgb(${rgb.join(",")})`;
    row.append(swatch, text);
    return row;
  }

  function showLegend() {
    const legend = document.getElementById("legend");
    legend.replaceChildren();
    const b = state.build;
    if (state.mode === "materials") {
      for (const m of b.materials) legend.append(swatchRow(state.materialRgb[m.index], `${m.index} ${m.name}`));
      return;
    }
    if (state.mode === "depth" || state.mode === "thickness") {
      const [lo, hi] = state.mode === "depth" ? [0, state.depthMax] : state.thicknessRange;
      const bar = document.createElement("canvas");
      bar.width = 200;
      bar.height = 1;
      const g = bar.getContext("2d");
      for (let i = 0; i < 200; i++) {
        g.fillStyle = `rgb(${ramp(i / 199).join(",")})`;
        g.fillRect(i, 0, 1, 1);
      }
      const scale = document.createElement("div");
      scale.className = "scale";
      scale.innerHTML = `<span>${lo.toFixed(2)} mm</span><span>${hi.toFixed(2)} mm</span>`;
      const what = state.mode === "depth"
        ? "distance of band voxels to the surface"
        : "colour-layer thickness of the nearest face";
      legend.append(document.createTextNode(what), bar, scale,
        swatchRow(OUTSIDE, "outside"), swatchRow(CORE, "core (deeper than the bands)"));
      return;
    }
    for (const layer of b.layers) {
      let text = `${layer.index} ${layer.name}`;
      if (layer.depth_mm !== null) text += ` (to ${layer.depth_mm.toFixed(2)} mm, median face)`;
      if (layer.colour && state.mode !== "layers") text += ": surface colour";
      legend.append(swatchRow(state.palette[layer.index], text));
    }
  }

  function showStatus() {
    const p = plane(state.axis);
    const g = state.build.grid;
    const i = state.index[state.axis];
    const mm = g.origin_mm[XYZ[state.axis]] + i * g.voxel_mm[XYZ[state.axis]];
    const n = g.shape_zyx[ZYX[state.axis]];
    let text = `${state.axis} = ${i} of 0..${n - 1} (${mm.toFixed(3)} mm)\n`;
    text += `slice ${p.nu} x ${p.nv} voxels (${p.u} x ${p.v})`;
    const image = state.image;
    if (image) {
      text += `\nshown: ${image.w} x ${image.h} samples, every ${image.region.cs} x ${image.region.rs} voxels`;
      text += `\nserver ${image.serverMs.toFixed(0)} ms, total ${image.totalMs.toFixed(0)} ms`;
    }
    document.getElementById("status").textContent = text;
    document.dispatchEvent(new CustomEvent("shellvox:section", {
      detail: { axis: state.axis, index: i, grid: g },
    }));
  }

  function showError(text) {
    const status = document.getElementById("status");
    status.classList.toggle("error", Boolean(text));
    if (text) status.textContent = text;
  }

  // ---- controls ----
  function setAxis(axis) {
    state.axis = axis;
    const n = state.build.grid.shape_zyx[ZYX[axis]];
    slider.max = number.max = String(n - 1);
    slider.value = number.value = String(state.index[axis]);
    for (const button of document.querySelectorAll("button.axis")) {
      button.classList.toggle("active", button.dataset.axis === axis);
    }
    fit();
    draw();
    showStatus();
    requestLoad();
  }

  function setMode(mode) {
    const button = document.querySelector(`button.mode[data-mode="${mode}"]`);
    if (!button || button.disabled) return;
    state.mode = mode;
    for (const b of document.querySelectorAll("button.mode")) b.classList.toggle("active", b === button);
    showLegend();
    requestLoad();
  }

  function setIndex(value) {
    const n = state.build.grid.shape_zyx[ZYX[state.axis]];
    const index = Math.max(0, Math.min(n - 1, Math.round(value)));
    state.index[state.axis] = index;
    slider.value = number.value = String(index);
    showStatus();
    requestLoad();
  }

  function zoom(factor, sx, sy) {
    const p = plane(state.axis);
    const { w, h } = size();
    const fitScale = 0.95 * Math.min(w / (p.nu * p.su), h / (p.nv * p.sv));
    const maxScale = 80 / Math.min(p.su, p.sv); // a voxel 80 px across
    const [u, v] = toPlane(sx, sy);
    state.scale = Math.max(fitScale / 4, Math.min(maxScale, state.scale * factor));
    const [u2, v2] = toPlane(sx, sy);
    state.cx += u - u2;
    state.cy += v - v2;
    draw();
    requestLoad();
  }

  function bindControls() {
    for (const button of document.querySelectorAll("button.axis")) {
      button.addEventListener("click", () => { state.moved = true; setAxis(button.dataset.axis); });
    }
    for (const button of document.querySelectorAll("button.mode")) {
      button.addEventListener("click", () => setMode(button.dataset.mode));
    }
    document.getElementById("fit").addEventListener("click", () => { fit(); draw(); requestLoad(); });
    slider.addEventListener("input", () => { state.moved = true; setIndex(Number(slider.value)); });
    number.addEventListener("change", () => { state.moved = true; setIndex(Number(number.value)); });
    let drag = null;
    canvas.addEventListener("pointerdown", (event) => {
      drag = { x: event.clientX, y: event.clientY, cx: state.cx, cy: state.cy, moved: false };
      canvas.setPointerCapture(event.pointerId);
    });
    canvas.addEventListener("pointermove", (event) => {
      if (!drag) return;
      const dx = event.clientX - drag.x;
      const dy = event.clientY - drag.y;
      if (Math.abs(dx) + Math.abs(dy) > 3) drag.moved = true;
      if (!drag.moved) return;
      state.cx = drag.cx - dx / state.scale;
      state.cy = drag.cy + dy / state.scale;
      draw();
    });
    canvas.addEventListener("pointerup", (event) => {
      if (!drag) return;
      const rect = canvas.getBoundingClientRect();
      if (drag.moved) requestLoad();
      else probeAt(event.clientX - rect.left, event.clientY - rect.top);
      drag = null;
    });
    canvas.addEventListener("wheel", (event) => {
      event.preventDefault();
      const rect = canvas.getBoundingClientRect();
      zoom(Math.exp(-event.deltaY * 0.0015), event.clientX - rect.left, event.clientY - rect.top);
    }, { passive: false });
    window.addEventListener("keydown", (event) => {
      if (event.target instanceof HTMLInputElement && event.target.type === "number") return;
      const step = event.shiftKey ? 10 : 1;
      const key = event.key;
      const { w, h } = size();
      if (["z", "y", "x", "ArrowRight", "ArrowUp", ".", "ArrowLeft", "ArrowDown", ",",
        "PageUp", "PageDown"].includes(key)) state.moved = true;
      if (key === "z" || key === "y" || key === "x") setAxis(key);
      else if (key >= "1" && key <= "6") setMode(MODES[Number(key) - 1]);
      else if (key === "ArrowRight" || key === "ArrowUp" || key === ".") setIndex(state.index[state.axis] + step);
      else if (key === "ArrowLeft" || key === "ArrowDown" || key === ",") setIndex(state.index[state.axis] - step);
      else if (key === "PageUp") setIndex(state.index[state.axis] + 10);
      else if (key === "PageDown") setIndex(state.index[state.axis] - 10);
      else if (key === "+" || key === "=") zoom(1.25, w / 2, h / 2);
      else if (key === "-") zoom(0.8, w / 2, h / 2);
      else if (key === "0") { fit(); draw(); requestLoad(); }
      else return;
      event.preventDefault();
    });
    new ResizeObserver(() => { draw(); requestLoad(); }).observe(canvas);
  }

  async function start() {
    const response = await fetch("/api/build");
    state.build = await response.json();
    const b = state.build;
    document.getElementById("build-name").textContent = b.input || b.folder;
    document.getElementById("build-name").title = b.folder;
    for (const axis of ["z", "y", "x"]) state.index[axis] = Math.floor(b.grid.shape_zyx[ZYX[axis]] / 2);
    // open on the slices with the most vivid colour (the server's pass over the pages);
    // if that takes longer than a moment, open mid-part and move there when it comes
    const opening = await fetchOpening(3);
    if (opening.ready) useOpening(opening);
    const materials = document.querySelector('button.mode[data-mode="materials"]');
    materials.disabled = !b.stacks.includes("materials");
    for (const mode of ["depth", "thickness"]) {
      const button = document.querySelector(`button.mode[data-mode="${mode}"]`);
      button.disabled = !b.depth;
      if (!b.depth) button.title = "this build has no thickness.ply (built with --thickness)";
    }
    preparePalettes();
    bindControls();
    setMode("colour");
    setAxis("z");
    if (!opening.ready) waitOpening();
  }

  async function fetchOpening(seconds) {
    const response = await fetch(`/api/opening?wait=${seconds}`);
    if (!response.ok) throw new Error(`opening slice: ${await response.text()}`);
    return response.json();
  }

  function useOpening(opening) {
    if (!opening.slices) return;
    for (const axis of ["z", "y", "x"]) state.index[axis] = opening.slices[axis];
    body.dataset.opening = ["z", "y", "x"].map((a) => `${a}:${opening.slices[a]}`).join(",");
  }

  async function waitOpening() {
    let opening = { ready: false };
    while (!opening.ready) opening = await fetchOpening(30);
    if (state.moved) return;
    useOpening(opening);
    setIndex(state.index[state.axis]);
  }

  // for scripts and tests: the state and the screen position of a voxel of the slice
  window.shellvoxView = {
    state,
    RAMP,
    voxelToClient(iu, iv) {
      const p = plane(state.axis);
      const [sx, sy] = toScreen(p.ou + iu * p.su, p.ov + iv * p.sv);
      const rect = canvas.getBoundingClientRect();
      return { x: rect.left + sx, y: rect.top + sy };
    },
  };

  start().catch((error) => {
    showError(String(error));
    body.dataset.status = "error";
  });
})();
