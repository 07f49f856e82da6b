// shellvox view: the model's surface in 3D (WebGL 2, no libraries), beside the slices.
//
// The server sends the surface once (/api/surface): each face's corners (mm), colour
// (sRGB, from colour.tif under the face) and colour-layer depth (mm). Faces are drawn
// flat, lit by a light at the camera (a face turned to the camera shows its colour
// exactly), coloured by the model's colour or by the depth on the slices' colour ramp.
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
  // views along the axes: azimuth and elevation (degrees) of the camera around the model
  const VIEWS = {
    top: [-90, 90], bottom: [-90, -90], front: [-90, 0], back: [90, 0],
    right: [0, 0], left: [180, 0], default: [-60, 35],
  };

  const view = {
    gl: null, surface: null, section: null, mode: "colour", name: "default",
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
  const SURFACE_VS = `#version 300 es
    in vec3 aPos; in vec3 aColour; in float aDepth;
    uniform mat4 uMatrix;
    out vec3 vPos; flat out vec3 vColour; flat out float vDepth;
    void main() { vPos = aPos; vColour = aColour; vDepth = aDepth; gl_Position = uMatrix * vec4(aPos, 1.0); }`;
  const SURFACE_FS = `#version 300 es
    precision highp float;
    in vec3 vPos; flat in vec3 vColour; flat in float vDepth;
    uniform int uMode; uniform float uDepthMax; uniform vec3 uRamp[5]; uniform vec3 uToCamera;
    uniform int uAxis; uniform float uPlane; uniform int uCut; uniform vec3 uCutColour;
    out vec4 outColour;
    vec3 ramp(float t) {
      float x = clamp(t, 0.0, 1.0) * 4.0;
      int i = min(3, int(floor(x)));
      return mix(uRamp[i], uRamp[i + 1], x - float(i));
    }
    void main() {
      vec3 n = normalize(cross(dFdx(vPos), dFdy(vPos)));
      float shade = 0.35 + 0.65 * abs(dot(n, uToCamera));
      vec3 c = (uMode == 0 ? vColour : ramp(vDepth / uDepthMax)) * shade;
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
    return { p, uniforms, aPos: gl.getAttribLocation(p, "aPos"),
      aColour: gl.getAttribLocation(p, "aColour"), aDepth: gl.getAttribLocation(p, "aDepth") };
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
    view.surfaceProgram = program(gl, SURFACE_VS, SURFACE_FS);
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
    gl.uniform1i(sp.uniforms.uMode, view.mode === "colour" ? 0 : 1);
    gl.uniform1f(sp.uniforms.uDepthMax, view.surface.depthMax);
    gl.uniform3fv(sp.uniforms.uRamp, new Float32Array(window.shellvoxView.RAMP.flat().map((c) => c / 255)));
    gl.uniform3fv(sp.uniforms.uToCamera, new Float32Array(toCamera));
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

  function showLegend() {
    const legend = document.getElementById("surface-legend");
    legend.replaceChildren();
    if (view.mode !== "depth" || !view.surface) return;
    const bar = document.createElement("canvas");
    bar.width = 200;
    bar.height = 1;
    const g = bar.getContext("2d");
    const ramp = window.shellvoxView.RAMP;
    for (let i = 0; i < 200; i++) {
      const x = (i / 199) * (ramp.length - 1);
      const k = Math.min(ramp.length - 2, Math.floor(x));
      const rgb = ramp[k].map((c, j) => Math.round(c + (ramp[k + 1][j] - c) * (x - k)));
      g.fillStyle = `rgb(${rgb.join(",")})`;
      g.fillRect(i, 0, 1, 1);
    }
    const scale = document.createElement("div");
    scale.className = "scale";
    scale.innerHTML = `<span>0 mm</span><span>${view.surface.depthMax.toFixed(2)} mm</span>`;
    legend.append(document.createTextNode("colour-layer depth of each face"), bar, scale);
  }

  function setMode(mode) {
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
    view, setView, setMode,
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
    return;
  }
  body.dataset.surface = "loading";
  load().catch((error) => {
    status.textContent = `surface: ${error.message || error}`;
    status.classList.add("error");
    body.dataset.surface = "error";
  });
})();
