// shellvox view: the model's surface in 3D (WebGL 2, no libraries), beside the slices.
//
// The server sends the surface once (/api/surface): each face's corners (mm), colour
// (sRGB, from colour.tif under the face) and colour-layer depth (mm); then, when the build
// has a soft proof (proof.ply), each face's predicted printed colour (sRGB), CIEDE2000
// error against the model's colour and gamut error (/api/proof, in the same face order).
// Faces are drawn flat, lit by a light at the camera (a face turned to the camera shows
// its colour exactly; the error's steps only lightly, 0.8 to 1, to stay readable), coloured by one of four modes: "colour" (the model's), "depth"
// (on the slices' colour ramp), "predicted" (the soft proof) and "de" (the error in the
// steps of the soft-proof picture, preview/soft_proof.png, hatched as it is over faces
// whose target is out of gamut). The error's scale is not written here: /api/build sends
// it (its "de_scale", from shellvox.voxel.io's DE_STEPS, DE_RGB, NO_PREDICTION_RGB,
// HATCH_RGB and HATCH_PERIOD).
// The current section (from viewer.js, event "shellvox:section") is drawn as a
// translucent plane over the grid, and where it cuts the surface as a line.
"use strict";

(() => {
  const canvas = document.getElementById("view3d");
  const panel = document.getElementById("stage3d");
  const body = document.body;
  const status = document.getElementById("surface-status");
  const XYZ = { x: 0, y: 1, z: 2 };
  const ZYX = { z: 0, y: 1, x: 2 };
  const FOV = (30 * Math.PI) / 180;
  const CUT_RGB = [0.93, 0.0, 0.36];
  const PLANE_RGBA = [0.17, 0.36, 0.61, 0.22];
  const MODES = { colour: 0, depth: 1, predicted: 2, de: 3 };
  const PROOF_MODES = ["predicted", "de"];
  // the predicted colour where the proof has none (the server's grey, lit as the others)
  const NONE_RGB = [160, 160, 160];
  // views along the axes: azimuth and elevation (degrees) of the camera around the model
  const VIEWS = {
    top: [-90, 90], bottom: [-90, -90], front: [-90, 0], back: [90, 0],
    right: [0, 0], left: [180, 0], default: [-60, 35],
  };

  const view = {
    gl: null, surface: null, proof: null, scale: null, section: null, mode: "colour", name: "default",
    azimuth: VIEWS.default[0], elevation: VIEWS.default[1], distance: 1, fit: 1,
    centre: [0, 0, 0], showPlane: true, pending: false, matrix: null,
  };

  // ---- small matrix helpers (column-major, as WebGL takes them) ----
  function multiply(a, b) {
    const out = new Float32Array(16);
    for (let c = 0; c < 4; c++) {
      for (let r = 0; r < 4; r++) {
        let sum = 0;
        for (let k = 0; k < 4; k++) sum += a[k * 4 + r] * b[c * 4 + k];
        out[c * 4 + r] = sum;
      }
    }
    return out;
  }
  function perspective(fovy, aspect, near, far) {
    const f = 1 / Math.tan(fovy / 2);
    const out = new Float32Array(16);
    out[0] = f / aspect; out[5] = f; out[10] = (far + near) / (near - far); out[11] = -1;
    out[14] = (2 * far * near) / (near - far);
    return out;
  }
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const unit = (a) => { const n = Math.hypot(...a) || 1; return a.map((v) => v / n); };
  function lookAt(eye, up) { // towards the origin (the model's centre)
    const f = unit(sub([0, 0, 0], eye));
    const s = unit(cross(f, up));
    const u = cross(s, f);
    return new Float32Array([
      s[0], u[0], -f[0], 0, s[1], u[1], -f[1], 0, s[2], u[2], -f[2], 0,
      -dot(s, eye), -dot(u, eye), dot(f, eye), 1,
    ]);
  }

  // ---- the camera: on a sphere around the model's centre ----
  function camera() {
    const az = (view.azimuth * Math.PI) / 180;
    const el = (view.elevation * Math.PI) / 180;
    const direction = [Math.cos(el) * Math.cos(az), Math.cos(el) * Math.sin(az), Math.sin(el)];
    const up = [-Math.cos(az) * Math.sin(el), -Math.sin(az) * Math.sin(el), Math.cos(el)];
    const eye = direction.map((v) => v * view.distance);
    const aspect = Math.max(1e-3, canvas.clientWidth / Math.max(1, canvas.clientHeight));
    const near = view.distance / 100;
    const far = view.distance * 10;
    return { matrix: multiply(perspective(FOV, aspect, near, far), lookAt(eye, up)), toCamera: direction };
  }

  function fitDistance() {
    const aspect = Math.max(1e-3, canvas.clientWidth / Math.max(1, canvas.clientHeight));
    const half = Math.min(FOV / 2, Math.atan(Math.tan(FOV / 2) * aspect));
    return (1.08 * view.radius) / Math.sin(half);
  }

  function setView(name) {
    const [azimuth, elevation] = VIEWS[name] || VIEWS.default;
    Object.assign(view, { name, azimuth, elevation });
    if (view.surface) view.distance = fitDistance();
    requestRender();
  }

  // ---- shaders ----
  // aDe and aGamut are -1 where the proof has no value
  const SURFACE_VS = `#version 300 es
    in vec3 aPos; in vec3 aColour; in float aDepth; in vec3 aPredicted; in float aDe; in float aGamut;
    uniform mat4 uMatrix;
    out vec3 vPos; flat out vec3 vColour; flat out float vDepth;
    flat out vec3 vPredicted; flat out float vDe; flat out float vGamut;
    void main() {
      vPos = aPos; vColour = aColour; vDepth = aDepth;
      vPredicted = aPredicted; vDe = aDe; vGamut = aGamut;
      gl_Position = uMatrix * vec4(aPos, 1.0);
    }`;
  // `steps`: the number of the error's steps (the scale's uDeLow and uDeRgb)
  const surfaceFs = (steps) => `#version 300 es
    precision highp float;
    in vec3 vPos; flat in vec3 vColour; flat in float vDepth;
    flat in vec3 vPredicted; flat in float vDe; flat in float vGamut;
    uniform int uMode; uniform float uDepthMax; uniform vec3 uRamp[5]; uniform vec3 uToCamera;
    uniform float uDeLow[${steps}]; uniform vec3 uDeRgb[${steps}];
    uniform float uInGamut; uniform vec3 uHatch; uniform vec3 uNoPrediction;
    uniform float uHatchPeriod; uniform float uHeight;
    uniform int uAxis; uniform float uPlane; uniform int uCut; uniform vec3 uCutColour;
    out vec4 outColour;
    vec3 ramp(float t) {
      float x = clamp(t, 0.0, 1.0) * 4.0;
      int i = min(3, int(floor(x)));
      return mix(uRamp[i], uRamp[i + 1], x - float(i));
    }
    // the last step whose lower bound is at most de (the first below its own)
    vec3 deColour(float de) {
      if (de < 0.0) return uNoPrediction;
      vec3 c = uDeRgb[0];
      for (int i = 1; i < ${steps}; i++) {
        if (de >= uDeLow[i]) c = uDeRgb[i];
      }
      return c;
    }
    void main() {
      vec3 n = normalize(cross(dFdx(vPos), dFdy(vPos)));
      // the error's steps are lit lightly (0.8 to 1), so a face still reads as its step
      float lit = abs(dot(n, uToCamera));
      float shade = uMode == 3 ? 0.8 + 0.2 * lit : 0.35 + 0.65 * lit;
      vec3 base = uMode == 0 ? vColour
        : uMode == 1 ? ramp(vDepth / uDepthMax)
        : uMode == 2 ? vPredicted
        : deColour(vDe);
      vec3 c = base * shade;
      // the picture's hatching: screen row + column (rows from the top) a multiple of the period
      float row = uHeight - 1.0 - floor(gl_FragCoord.y);
      bool line = mod(floor(gl_FragCoord.x) + row, uHatchPeriod) < 0.5;
      if (uMode == 3 && vGamut > uInGamut && line) c = uHatch;
      float p = vPos[uAxis];
      if (uCut == 1 && abs(p - uPlane) < 1.25 * max(fwidth(p), 1e-6)) c = uCutColour;
      outColour = vec4(c, 1.0);
    }`;
  const PLANE_VS = `#version 300 es
    in vec3 aPos; uniform mat4 uMatrix;
    void main() { gl_Position = uMatrix * vec4(aPos, 1.0); }`;
  const PLANE_FS = `#version 300 es
    precision highp float; uniform vec4 uColour; out vec4 outColour;
    void main() { outColour = uColour; }`;

  function program(gl, vs, fs) {
    const p = gl.createProgram();
    for (const [type, source] of [[gl.VERTEX_SHADER, vs], [gl.FRAGMENT_SHADER, fs]]) {
      const shader = gl.createShader(type);
      gl.shaderSource(shader, source);
      gl.compileShader(shader);
      if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(shader));
      gl.attachShader(p, shader);
    }
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
    const uniforms = {};
    for (let i = 0; i < gl.getProgramParameter(p, gl.ACTIVE_UNIFORMS); i++) {
      const name = gl.getActiveUniform(p, i).name.replace(/\[0\]$/, "");
      uniforms[name] = gl.getUniformLocation(p, name);
    }
    const attributes = {};
    for (const name of ["aPos", "aColour", "aDepth", "aPredicted", "aDe", "aGamut"]) {
      attributes[name] = gl.getAttribLocation(p, name);
    }
    return { p, uniforms, ...attributes };
  }

  function buffer(gl, data, location, size, type, normalized) {
    const b = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, b);
    gl.bufferData(gl.ARRAY_BUFFER, data, gl.STATIC_DRAW);
    gl.enableVertexAttribArray(location);
    gl.vertexAttribPointer(location, size, type, normalized, 0, 0);
    return b;
  }

  // ---- loading the surface ----
  async function load() {
    view.build = await (await fetch("/api/build")).json();
    view.scale = view.build.de_scale;
    const response = await fetch("/api/surface");
    if (response.status === 404) {
      status.textContent = await response.text();
      body.dataset.surface = "none";
      return;
    }
    if (!response.ok) throw new Error(await response.text());
    const faces = Number(response.headers.get("X-Faces"));
    const source = Number(response.headers.get("X-Source-Faces"));
    const depthMax = Number(response.headers.get("X-Depth-Range").split(",")[1]);
    const data = await response.arrayBuffer();
    const corners = new Float32Array(data, 0, faces * 9);
    const depth = new Float32Array(data, faces * 36, faces);
    const colour = new Uint8Array(data, faces * 40, faces * 3);
    // centre the model at the origin (float32 precision), one vertex per corner
    const low = [Infinity, Infinity, Infinity];
    const high = [-Infinity, -Infinity, -Infinity];
    for (let i = 0; i < corners.length; i++) {
      const a = i % 3;
      if (corners[i] < low[a]) low[a] = corners[i];
      if (corners[i] > high[a]) high[a] = corners[i];
    }
    view.centre = low.map((v, a) => (v + high[a]) / 2);
    view.radius = Math.max(1e-6, Math.hypot(...sub(high, low)) / 2);
    const positions = new Float32Array(faces * 9);
    for (let i = 0; i < positions.length; i++) positions[i] = corners[i] - view.centre[i % 3];
    const vertexColour = new Uint8Array(faces * 9);
    const vertexDepth = new Float32Array(faces * 3);
    for (let f = 0; f < faces; f++) {
      for (let k = 0; k < 3; k++) {
        vertexDepth[3 * f + k] = depth[f];
        for (let c = 0; c < 3; c++) vertexColour[9 * f + 3 * k + c] = colour[3 * f + c];
      }
    }
    const gl = view.gl;
    view.surfaceProgram = program(gl, SURFACE_VS, surfaceFs(view.scale.steps.length));
    view.planeProgram = program(gl, PLANE_VS, PLANE_FS);
    const sp = view.surfaceProgram;
    view.surfaceVao = gl.createVertexArray();
    gl.bindVertexArray(view.surfaceVao);
    buffer(gl, positions, sp.aPos, 3, gl.FLOAT, false);
    buffer(gl, vertexColour, sp.aColour, 3, gl.UNSIGNED_BYTE, true);
    buffer(gl, vertexDepth, sp.aDepth, 1, gl.FLOAT, false);
    view.planeVao = gl.createVertexArray();
    gl.bindVertexArray(view.planeVao);
    view.planeBuffer = buffer(gl, new Float32Array(12), view.planeProgram.aPos, 3, gl.FLOAT, false);
    gl.bindVertexArray(null);
    view.surface = { faces, source, depthMax };
    view.distance = fitDistance();
    let shown = `${faces} faces`;
    if (faces < source) shown += ` (thickness.ply's ${source} decimated)`;
    if (faces > source) shown += ` (thickness.ply's ${source} split to show the colour)`;
    status.textContent = shown;
    view.surfaceShown = shown;
    showLegend();
    requestRender();
  }

  function proofButtons() {
    return PROOF_MODES.map((mode) => document.querySelector(`button.surface-mode[data-mode="${mode}"]`));
  }

  // the soft proof at the faces, once the surface is there; without it the modes stay off
  async function loadProof() {
    const response = view.build.proof ? await fetch("/api/proof") : null;
    if (!response || !response.ok) {
      const none = !response || response.status === 404;
      const why = none
        ? "this build has no soft proof (proof.ply, made by builds with materials and a colour report)"
        : (await response.text()).trim();
      for (const b of proofButtons()) b.title = why;
      status.textContent = `${view.surfaceShown}; ${none
        ? "no soft proof (proof.ply) in this build: no predicted or ΔE view"
        : `soft proof: ${why}`}`;
      body.dataset.proof = none ? "none" : "error";
      return;
    }
    const faces = Number(response.headers.get("X-Faces"));
    if (faces !== view.surface.faces) throw new Error(`soft proof of ${faces} faces, surface of ${view.surface.faces}`);
    const optics = response.headers.get("X-Optics");
    const inGamut = Number(response.headers.get("X-In-Gamut-DE"));
    const data = await response.arrayBuffer();
    const de = new Float32Array(data, 0, faces);
    const gamut = new Float32Array(data, faces * 4, faces);
    const predicted = new Uint8Array(data, faces * 8, faces * 3);
    const vertexPredicted = new Uint8Array(faces * 9);
    const vertexDe = new Float32Array(faces * 3);
    const vertexGamut = new Float32Array(faces * 3);
    for (let f = 0; f < faces; f++) {
      for (let k = 0; k < 3; k++) {
        vertexDe[3 * f + k] = Number.isNaN(de[f]) ? -1 : de[f];
        vertexGamut[3 * f + k] = Number.isNaN(gamut[f]) ? -1 : gamut[f];
        for (let c = 0; c < 3; c++) vertexPredicted[9 * f + 3 * k + c] = predicted[3 * f + c];
      }
    }
    const gl = view.gl;
    const sp = view.surfaceProgram;
    gl.bindVertexArray(view.surfaceVao);
    buffer(gl, vertexPredicted, sp.aPredicted, 3, gl.UNSIGNED_BYTE, true);
    buffer(gl, vertexDe, sp.aDe, 1, gl.FLOAT, false);
    buffer(gl, vertexGamut, sp.aGamut, 1, gl.FLOAT, false);
    gl.bindVertexArray(null);
    view.proof = { optics, inGamut };
    const note = optics === "measured" ? "measured optics" : "assumed optics";
    for (const b of proofButtons()) {
      b.disabled = false;
      b.title = `${b.dataset.title} (soft proof, ${note})`;
    }
    body.dataset.proof = "ready";
    showLegend();
    requestRender();
  }

  // ---- drawing ----
  function requestRender() {
    if (view.pending) return;
    view.pending = true;
    requestAnimationFrame(render);
  }

  function planeCorners() {
    const s = view.section;
    if (!s) return null;
    const g = s.grid;
    const a = XYZ[s.axis];
    const corner = (axis, end) => {
      const i = XYZ[axis];
      const n = g.shape_zyx[ZYX[axis]];
      return g.origin_mm[i] + (end ? n - 0.5 : -0.5) * g.voxel_mm[i] - view.centre[i];
    };
    const others = ["x", "y", "z"].filter((axis) => axis !== s.axis);
    const at = g.origin_mm[a] + s.index * g.voxel_mm[a] - view.centre[a];
    const points = [];
    for (const [e0, e1] of [[0, 0], [1, 0], [1, 1], [0, 1]]) {
      const p = [0, 0, 0];
      p[a] = at;
      p[XYZ[others[0]]] = corner(others[0], e0);
      p[XYZ[others[1]]] = corner(others[1], e1);
      points.push(...p);
    }
    return { points: new Float32Array(points), axis: a, at };
  }

  function render() {
    view.pending = false;
    const gl = view.gl;
    const dpr = window.devicePixelRatio || 1;
    const w = Math.round(canvas.clientWidth * dpr);
    const h = Math.round(canvas.clientHeight * dpr);
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    gl.viewport(0, 0, w, h);
    gl.clearColor(220 / 255, 220 / 255, 220 / 255, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    if (!view.surface) return;
    const { matrix, toCamera } = camera();
    view.matrix = matrix;
    const plane = planeCorners();
    const sp = view.surfaceProgram;
    gl.enable(gl.DEPTH_TEST);
    gl.disable(gl.BLEND);
    gl.depthMask(true);
    gl.useProgram(sp.p);
    gl.uniformMatrix4fv(sp.uniforms.uMatrix, false, matrix);
    gl.uniform1i(sp.uniforms.uMode, MODES[view.mode]);
    gl.uniform1f(sp.uniforms.uDepthMax, view.surface.depthMax);
    gl.uniform3fv(sp.uniforms.uRamp, new Float32Array(window.shellvoxView.RAMP.flat().map((c) => c / 255)));
    gl.uniform3fv(sp.uniforms.uToCamera, new Float32Array(toCamera));
    const scale = view.scale;
    const unitRgb = (rgb) => rgb.map((c) => c / 255);
    gl.uniform1fv(sp.uniforms.uDeLow, new Float32Array(scale.steps.map((step) => step.low)));
    gl.uniform3fv(sp.uniforms.uDeRgb, new Float32Array(scale.steps.flatMap((step) => unitRgb(step.srgb))));
    gl.uniform1f(sp.uniforms.uInGamut, view.proof ? view.proof.inGamut : 1);
    gl.uniform3fv(sp.uniforms.uHatch, new Float32Array(unitRgb(scale.hatch_srgb)));
    gl.uniform3fv(sp.uniforms.uNoPrediction, new Float32Array(unitRgb(scale.no_prediction_srgb)));
    gl.uniform1f(sp.uniforms.uHatchPeriod, scale.hatch_period_px);
    gl.uniform1f(sp.uniforms.uHeight, h);
    gl.uniform1i(sp.uniforms.uAxis, plane ? plane.axis : 0);
    gl.uniform1f(sp.uniforms.uPlane, plane ? plane.at : 0);
    gl.uniform1i(sp.uniforms.uCut, plane && view.showPlane ? 1 : 0);
    gl.uniform3fv(sp.uniforms.uCutColour, new Float32Array(CUT_RGB));
    gl.bindVertexArray(view.surfaceVao);
    gl.drawArrays(gl.TRIANGLES, 0, view.surface.faces * 3);
    if (plane && view.showPlane) {
      const pp = view.planeProgram;
      gl.useProgram(pp.p);
      gl.uniformMatrix4fv(pp.uniforms.uMatrix, false, matrix);
      gl.bindVertexArray(view.planeVao);
      gl.bindBuffer(gl.ARRAY_BUFFER, view.planeBuffer);
      gl.bufferData(gl.ARRAY_BUFFER, plane.points, gl.DYNAMIC_DRAW);
      gl.enable(gl.BLEND);
      gl.blendFunc(gl.SRC_ALPHA, gl.ONE_MINUS_SRC_ALPHA);
      gl.depthMask(false);
      gl.uniform4fv(pp.uniforms.uColour, new Float32Array(PLANE_RGBA));
      gl.drawArrays(gl.TRIANGLE_FAN, 0, 4);
      gl.uniform4fv(pp.uniforms.uColour, new Float32Array([...PLANE_RGBA.slice(0, 3), 0.9]));
      gl.drawArrays(gl.LINE_LOOP, 0, 4);
      gl.depthMask(true);
    }
    gl.bindVertexArray(null);
    const s = view.section;
    body.dataset.surface = `${view.mode}:${view.name}:${s ? `${s.axis}:${s.index}` : "-"}`;
  }

  // a colour bar: `stops` (sRGB) evenly along it, linearly between them
  function colourBar(stops) {
    const bar = document.createElement("canvas");
    bar.width = 200;
    bar.height = 1;
    const g = bar.getContext("2d");
    for (let i = 0; i < 200; i++) {
      const x = (i / 199) * (stops.length - 1);
      const k = Math.min(stops.length - 2, Math.floor(x));
      const rgb = stops[k].map((c, j) => Math.round(c + (stops[k + 1][j] - c) * (x - k)));
      g.fillStyle = `rgb(${rgb.join(",")})`;
      g.fillRect(i, 0, 1, 1);
    }
    return bar;
  }

  function legendRow(swatchStyle, text) {
    const row = document.createElement("div");
    const swatch = document.createElement("span");
    swatch.className = "swatch";
    swatch.style.background = swatchStyle;
    row.append(swatch, document.createTextNode(text));
    return row;
  }

  // the hatching's swatch, as the picture's legend draws it: the first step's colour with
  // the hatching's lines over it, pixel for pixel
  function hatchSwatch() {
    const scale = view.scale;
    const swatch = document.createElement("canvas");
    swatch.className = "swatch";
    swatch.width = 12;
    swatch.height = 12;
    const g = swatch.getContext("2d");
    g.fillStyle = `rgb(${scale.steps[0].srgb.join(",")})`;
    g.fillRect(0, 0, 12, 12);
    g.fillStyle = `rgb(${scale.hatch_srgb.join(",")})`;
    for (let r = 0; r < 12; r++) {
      for (let c = 0; c < 12; c++) if ((r + c) % scale.hatch_period_px === 0) g.fillRect(c, r, 1, 1);
    }
    return swatch;
  }

  function opticsNote() {
    const note = document.createElement("div");
    note.id = "surface-optics";
    note.dataset.optics = view.proof.optics;
    note.className = "note";
    note.textContent = view.proof.optics === "measured"
      ? "Predicted with measured optics (a calibrated profile)."
      : "Predicted with assumed optics (the profile's defaults) until a measured colour chart calibrates them.";
    return note;
  }

  function showLegend() {
    const legend = document.getElementById("surface-legend");
    legend.replaceChildren();
    if (!view.surface) return;
    const rgb = (c) => `rgb(${c.join(",")})`;
    if (view.mode === "depth") {
      const scale = document.createElement("div");
      scale.className = "scale";
      scale.innerHTML = `<span>0 mm</span><span>${view.surface.depthMax.toFixed(2)} mm</span>`;
      legend.append(document.createTextNode("colour-layer depth of each face"),
        colourBar(window.shellvoxView.RAMP), scale);
    } else if (view.mode === "predicted" && view.proof) {
      legend.append(document.createTextNode("printed colour predicted from the voxels (soft proof)"),
        legendRow(rgb(NONE_RGB), "no prediction"), opticsNote());
    } else if (view.mode === "de" && view.proof) {
      const steps = document.createElement("div");
      steps.id = "de-scale";
      for (const step of view.scale.steps) {
        const row = legendRow(rgb(step.srgb), step.label);
        row.className = "step";
        steps.append(row);
      }
      const hatched = document.createElement("div");
      hatched.id = "de-hatched";
      hatched.append(hatchSwatch(),
        document.createTextNode(`hatched: target out of gamut (gamut ΔE > ${view.proof.inGamut})`));
      const none = legendRow(rgb(view.scale.no_prediction_srgb), "no prediction");
      none.id = "de-none";
      legend.append(
        document.createTextNode("ΔE (CIEDE2000), predicted against the model's colour"),
        steps, hatched, none, opticsNote());
    }
  }

  function setMode(mode) {
    if (!(mode in MODES) || (PROOF_MODES.includes(mode) && !view.proof)) return;
    view.mode = mode;
    for (const b of document.querySelectorAll("button.surface-mode")) b.classList.toggle("active", b.dataset.mode === mode);
    showLegend();
    requestRender();
  }

  // ---- controls ----
  function bind() {
    for (const b of document.querySelectorAll("button.surface-mode")) b.addEventListener("click", () => setMode(b.dataset.mode));
    for (const b of document.querySelectorAll("button.surface-view")) b.addEventListener("click", () => setView(b.dataset.view));
    document.getElementById("show-plane").addEventListener("change", (event) => {
      view.showPlane = event.target.checked;
      requestRender();
    });
    document.getElementById("toggle3d").addEventListener("click", (event) => {
      panel.classList.toggle("hidden");
      event.target.classList.toggle("active", !panel.classList.contains("hidden"));
    });
    let drag = null;
    canvas.addEventListener("pointerdown", (event) => {
      drag = { x: event.clientX, y: event.clientY, azimuth: view.azimuth, elevation: view.elevation };
      canvas.setPointerCapture(event.pointerId);
    });
    canvas.addEventListener("pointermove", (event) => {
      if (!drag) return;
      view.azimuth = drag.azimuth - (event.clientX - drag.x) * 0.4;
      view.elevation = Math.max(-90, Math.min(90, drag.elevation + (event.clientY - drag.y) * 0.4));
      view.name = "turned";
      requestRender();
    });
    canvas.addEventListener("pointerup", () => { drag = null; });
    canvas.addEventListener("wheel", (event) => {
      event.preventDefault();
      const fit = fitDistance();
      view.distance = Math.max(fit / 50, Math.min(fit * 5, view.distance * Math.exp(event.deltaY * 0.0015)));
      requestRender();
    }, { passive: false });
    canvas.addEventListener("dblclick", () => setView("default"));
    document.addEventListener("shellvox:section", (event) => { view.section = event.detail; requestRender(); });
    new ResizeObserver(() => requestRender()).observe(canvas);
  }

  // for scripts and tests: the view, and the client position of a point (mm)
  window.shellvoxSurface = {
    view, setView, setMode, NONE_RGB,
    project(point) {
      const p = sub(point, view.centre);
      const m = view.matrix;
      const clip = [0, 1, 2, 3].map((r) => m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r]);
      const rect = canvas.getBoundingClientRect();
      return {
        x: rect.left + ((clip[0] / clip[3] + 1) / 2) * canvas.clientWidth,
        y: rect.top + ((1 - clip[1] / clip[3]) / 2) * canvas.clientHeight,
      };
    },
  };

  view.gl = canvas.getContext("webgl2", { antialias: true, preserveDrawingBuffer: true });
  bind();
  setMode("colour");
  if (!view.gl) {
    status.textContent = "this browser has no WebGL 2: no 3D view";
    body.dataset.surface = "none";
    body.dataset.proof = "none";
    return;
  }
  body.dataset.surface = "loading";
  body.dataset.proof = "loading";
  load().then(
    () => {
      if (!view.surface) {
        body.dataset.proof = "none";
        return undefined;
      }
      return loadProof().catch((error) => {
        status.textContent = `${view.surfaceShown}; soft proof: ${error.message || error}`;
        status.classList.add("error");
        body.dataset.proof = "error";
      });
    },
    (error) => {
      status.textContent = `surface: ${error.message || error}`;
      status.classList.add("error");
      body.dataset.surface = "error";
      body.dataset.proof = "none";
    },
  );
})();
