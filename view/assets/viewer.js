// The lieflow animation page: draws a run's frames (data in #lieflow-data) with three.js
// (window.THREE, vendored in the page). Points are spheres sized by mass, rigid bodies their
// solid with their axes, rods/joints/springs/dashpots lines, constraint surfaces faint; the
// paths of traced bodies; play, pause, scrub, speed; an orbit camera in 3D, a fixed plane in
// 2D; the outputs as small plots; events on the time line. Its state for tests is in
// window.lieflowViewer and in #lieflow-status (JSON).
(function () {
  'use strict';
  const T = window.THREE;
  const D = JSON.parse(document.getElementById('lieflow-data').textContent);
  const status = { ready: false, errors: window.lieflowErrors || [], frame: 0, frames: D.frames };
  window.lieflowViewer = status;

  function floats(b64) {
    const bin = atob(b64);
    const bytes = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    return new Float32Array(bytes.buffer);
  }
  const F = D.frames, S = D.slots;
  const pos = floats(D.positions); // F × S × 3
  const times = D.times, steps = D.steps;
  const outputs = D.outputs.names.length ? floats(D.outputs.values) : new Float32Array(0);
  const nOut = D.outputs.names.length;

  // Scene size from every frame's positions.
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  const centreSlots = D.bodies.map(b => b.slot);
  for (let f = 0; f < F; f++) for (const s of centreSlots) for (let k = 0; k < 3; k++) {
    const v = pos[(f * S + s) * 3 + k];
    if (v < lo[k]) lo[k] = v;
    if (v > hi[k]) hi[k] = v;
  }
  for (const l of D.links) for (const e of [l.a, l.b]) if (e.world) for (let k = 0; k < 3; k++) {
    lo[k] = Math.min(lo[k], e.world[k]); hi[k] = Math.max(hi[k], e.world[k]);
  }
  const pad = Math.max(0, ...D.bodies.filter(b => b.rigid).map(b => extent(b.rigid.shape)));
  for (let k = 0; k < 3; k++) { lo[k] -= pad; hi[k] += pad; }
  if (!isFinite(lo[0])) { lo.fill(-1); hi.fill(1); }
  const centre = lo.map((v, k) => (v + hi[k]) / 2);
  let size = Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
  if (!(size > 0)) size = 1;
  function extent(sh) {
    if (sh.kind === 'sphere') return sh.radius;
    if (sh.kind === 'cylinder') return Math.hypot(sh.radius, sh.height / 2);
    return Math.hypot(sh.size[0], sh.size[1], sh.size[2]) / 2;
  }

  // Point radius: a fraction of the scene, by mass^(1/3), below half the shortest rod.
  const at = (f, s) => [pos[(f * S + s) * 3], pos[(f * S + s) * 3 + 1], pos[(f * S + s) * 3 + 2]];
  let shortest = Infinity;
  for (const l of D.links) if (l.kind === 'rod' || l.kind === 'spring') {
    const a = endAt(l.a, 0), b = endAt(l.b, 0);
    const len = Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
    if (len > 0) shortest = Math.min(shortest, len);
  }
  const points = D.bodies.filter(b => !b.rigid);
  const mMax = Math.max(1e-300, ...points.map(b => b.mass));
  const rMax = Math.min(size * 0.025, 0.3 * shortest);
  const radius = b => rMax * Math.max(0.4, Math.cbrt(b.mass / mMax));

  // The frame R of rigid body b at frame f: R = Q Pᵀ (or Q for an inertia box).
  function frameOf(b, f) {
    const Q = [[0, 0, 0], [0, 0, 0], [0, 0, 0]]; // Q[i][k]: component i of director k
    const ds = b.rigid.directors;
    for (let k = 0; k < 3; k++) {
      const d = k < ds.length ? at(f, ds[k]) : [0, 0, 1];
      for (let i = 0; i < 3; i++) Q[i][k] = d[i];
    }
    if (b.rigid.shape.kind === 'inertia-box') return Q;
    const P = b.rigid.axes; // P[k]: column k
    const R = [[0, 0, 0], [0, 0, 0], [0, 0, 0]];
    for (let i = 0; i < 3; i++) for (let j = 0; j < 3; j++) {
      let s = 0;
      for (let k = 0; k < 3; k++) s += Q[i][k] * P[k][j];
      R[i][j] = s;
    }
    return R;
  }
  function endAt(e, f) {
    if (e.world) return e.world;
    const b = D.bodies[e.body], c = at(f, b.slot);
    if (!b.rigid) return [c[0] + e.offset[0], c[1] + e.offset[1], c[2] + e.offset[2]];
    const R = frameOf(b, f), o = e.offset;
    return [0, 1, 2].map(i => c[i] + R[i][0] * o[0] + R[i][1] * o[1] + R[i][2] * o[2]);
  }

  // Renderer, scene, camera.
  const view = document.getElementById('view');
  const renderer = new T.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  view.appendChild(renderer.domElement);
  const scene = new T.Scene();
  const BACKGROUND = 0xf4f5f7;
  scene.background = new T.Color(BACKGROUND);
  scene.add(new T.HemisphereLight(0xffffff, 0x8090a0, 2.2));
  const sun = new T.DirectionalLight(0xffffff, 1.6);
  sun.position.set(1, -2, 3);
  scene.add(sun);
  const planar = D.dim === 2;
  let camera;
  if (planar) {
    camera = new T.OrthographicCamera(-1, 1, 1, -1, -10 * size, 10 * size);
    camera.position.set(centre[0], centre[1], size);
  } else {
    camera = new T.PerspectiveCamera(40, 1, size * 1e-3, size * 100);
    camera.up.set(0, 0, 1);
    const dir = [0.55, -1.5, 0.7], n = Math.hypot(...dir);
    const dist = 1.05 * size;
    camera.position.set(centre[0] + dir[0] / n * dist, centre[1] + dir[1] / n * dist, centre[2] + dir[2] / n * dist);
  }
  const controls = new T.OrbitControls(camera, renderer.domElement);
  controls.target.set(centre[0], centre[1], planar ? 0 : centre[2]);
  if (planar) {
    controls.enableRotate = false;
    controls.screenSpacePanning = true;
  }
  controls.update();
  controls.saveState();
  controls.addEventListener('change', render);

  if (!planar) {
    const grid = new T.GridHelper(2 * size, 20, 0xc8ccd4, 0xdde0e6);
    grid.rotation.x = Math.PI / 2;
    grid.position.set(centre[0], centre[1], lo[2] - 0.02 * size);
    scene.add(grid);
  }

  // Surfaces, faint.
  const faint = new T.MeshBasicMaterial({ color: 0x6080c0, transparent: true, opacity: 0.08, side: T.DoubleSide, depthWrite: false });
  const faintLine = new T.LineBasicMaterial({ color: 0x90a0c0 });
  for (const s of D.surfaces) {
    if (s.kind === 'sphere') {
      if (planar) {
        const pts = [];
        for (let i = 0; i <= 96; i++) {
          const a = 2 * Math.PI * i / 96;
          pts.push(new T.Vector3(s.centre[0] + s.radius * Math.cos(a), s.centre[1] + s.radius * Math.sin(a), -0.01 * size));
        }
        scene.add(new T.Line(new T.BufferGeometry().setFromPoints(pts), faintLine));
      } else {
        const m = new T.Mesh(new T.SphereGeometry(s.radius, 48, 24), faint);
        m.position.set(...s.centre);
        scene.add(m);
      }
    } else {
      const n = new T.Vector3(...s.normal).normalize();
      const c = new T.Vector3(...centre);
      const p = c.clone().addScaledVector(n, s.offset - c.dot(n));
      if (planar) {
        const t = new T.Vector3(-n.y, n.x, 0).multiplyScalar(size);
        scene.add(new T.Line(new T.BufferGeometry().setFromPoints([p.clone().sub(t), p.clone().add(t)]), faintLine));
      } else {
        const m = new T.Mesh(new T.PlaneGeometry(1.5 * size, 1.5 * size), faint);
        m.quaternion.setFromUnitVectors(new T.Vector3(0, 0, 1), n);
        m.position.copy(p);
        scene.add(m);
      }
    }
  }

  // Points: one instanced mesh.
  const palette = [0x2f6fb3, 0xd0632b, 0x3a9a4a, 0x9b4fb0, 0xc0392b, 0x1f9fa0, 0xb08a1f, 0x555b66];
  const pointMesh = new T.InstancedMesh(new T.SphereGeometry(1, 20, 14), new T.MeshStandardMaterial({ roughness: 0.45, metalness: 0.1 }), Math.max(1, points.length));
  pointMesh.count = points.length;
  const groupColour = {};
  points.forEach((b, i) => {
    const group = b.name.includes('.') ? b.name.slice(0, b.name.lastIndexOf('.')) : b.name;
    if (!(group in groupColour)) groupColour[group] = palette[Object.keys(groupColour).length % palette.length];
    pointMesh.setColorAt(i, new T.Color(groupColour[group]));
  });
  scene.add(pointMesh);
  const m4 = new T.Matrix4();

  // Rigid bodies: their solid and axes.
  const solids = [];
  D.bodies.forEach((b, i) => {
    if (!b.rigid) return;
    const sh = b.rigid.shape;
    let geo;
    if (sh.kind === 'sphere') geo = new T.SphereGeometry(sh.radius, 32, 20);
    else if (sh.kind === 'cylinder') { geo = new T.CylinderGeometry(sh.radius, sh.radius, sh.height, 40); geo.rotateX(Math.PI / 2); }
    else geo = new T.BoxGeometry(Math.max(sh.size[0], 1e-3 * size), Math.max(sh.size[1], 1e-3 * size), Math.max(sh.size[2], 1e-3 * size));
    const colour = palette[i % palette.length];
    const g = new T.Group();
    g.matrixAutoUpdate = false;
    g.add(new T.Mesh(geo, new T.MeshStandardMaterial({ color: colour, roughness: 0.5, metalness: 0.15, transparent: true, opacity: 0.82 })));
    g.add(new T.LineSegments(new T.EdgesGeometry(geo, 30), new T.LineBasicMaterial({ color: 0x30343a })));
    const L = 0.75 * extent(sh) + 1e-3 * size;
    const axes = new T.BufferGeometry();
    axes.setAttribute('position', new T.Float32BufferAttribute([0, 0, 0, L, 0, 0, 0, 0, 0, 0, L, 0, 0, 0, 0, 0, 0, L], 3));
    axes.setAttribute('color', new T.Float32BufferAttribute([1, 0, 0, 1, 0, 0, 0, 0.6, 0, 0, 0.6, 0, 0, 0, 1, 0, 0, 1], 3));
    const ax = new T.LineSegments(axes, new T.LineBasicMaterial({ vertexColors: true, depthTest: false }));
    ax.renderOrder = 2;
    g.add(ax);
    scene.add(g);
    solids.push({ b, g });
  });

  // Links: straight ones in one buffer; springs as coils.
  const straight = D.links.filter(l => l.kind !== 'spring');
  const springs = D.links.filter(l => l.kind === 'spring');
  const linkGeo = new T.BufferGeometry();
  const linkPos = new Float32Array(Math.max(1, straight.length) * 6);
  linkGeo.setAttribute('position', new T.BufferAttribute(linkPos, 3));
  const linkColours = new Float32Array(Math.max(1, straight.length) * 6);
  const kindColour = { rod: [0.35, 0.38, 0.42], pin: [0.35, 0.38, 0.42], dashpot: [0.75, 0.35, 0.1] };
  straight.forEach((l, i) => {
    const c = kindColour[l.kind] || [0.1, 0.1, 0.1];
    linkColours.set([...c, ...c], 6 * i);
  });
  linkGeo.setAttribute('color', new T.BufferAttribute(linkColours, 3));
  scene.add(new T.LineSegments(linkGeo, new T.LineBasicMaterial({ vertexColors: true })));
  const jointMarks = straight.map(l => {
    if (l.kind === 'dashpot' || (l.kind === 'rod' && !l.b.world)) return null;
    const m = new T.Mesh(new T.SphereGeometry(rMax > 0 && isFinite(rMax) ? 0.45 * rMax : 0.01 * size, 12, 8), new T.MeshStandardMaterial({ color: 0x222222 }));
    scene.add(m);
    return m;
  });
  const COIL = 96;
  const coils = springs.map(() => {
    const g = new T.BufferGeometry();
    g.setAttribute('position', new T.BufferAttribute(new Float32Array(COIL * 3), 3));
    const line = new T.Line(g, new T.LineBasicMaterial({ color: 0x3a9a4a }));
    scene.add(line);
    return g;
  });
  function coil(g, a, b) {
    const arr = g.attributes.position.array;
    const d = new T.Vector3(b[0] - a[0], b[1] - a[1], b[2] - a[2]);
    const len = d.length() || 1;
    const u = d.clone().divideScalar(len);
    const p = planar ? new T.Vector3(-u.y, u.x, 0) : new T.Vector3().crossVectors(u, Math.abs(u.z) < 0.9 ? new T.Vector3(0, 0, 1) : new T.Vector3(1, 0, 0)).normalize();
    const q = new T.Vector3().crossVectors(u, p);
    const r = Math.min(0.08 * len + 0.2 * rMax, size * 0.02);
    for (let i = 0; i < COIL; i++) {
      const s = i / (COIL - 1), ends = s < 0.08 || s > 0.92 ? 0 : 1;
      const a2 = 2 * Math.PI * 10 * s;
      const x = a[0] + d.x * s + ends * r * (p.x * Math.cos(a2) + (planar ? 0 : q.x * Math.sin(a2)));
      const y = a[1] + d.y * s + ends * r * (p.y * Math.cos(a2) + (planar ? 0 : q.y * Math.sin(a2)));
      const z = a[2] + d.z * s + ends * r * (p.z * Math.cos(a2) + (planar ? 0 : q.z * Math.sin(a2)));
      arr.set([x, y, z], 3 * i);
    }
    g.attributes.position.needsUpdate = true;
  }

  // Paths of traced bodies, drawn up to the current frame.
  const traces = D.traces.map((bi, i) => {
    const b = D.bodies[bi], arr = new Float32Array(F * 3);
    for (let f = 0; f < F; f++) arr.set(at(f, b.slot), 3 * f);
    const g = new T.BufferGeometry();
    g.setAttribute('position', new T.BufferAttribute(arr, 3));
    const line = new T.Line(g, new T.LineBasicMaterial({ color: palette[(i + 1) % palette.length], transparent: true, opacity: 0.7 }));
    scene.add(line);
    return g;
  });

  function place(f) {
    points.forEach((b, i) => {
      const r = radius(b);
      const c = at(f, b.slot);
      m4.makeScale(r, r, r).setPosition(c[0], c[1], c[2]);
      pointMesh.setMatrixAt(i, m4);
    });
    pointMesh.instanceMatrix.needsUpdate = true;
    for (const { b, g } of solids) {
      const R = frameOf(b, f), c = at(f, b.slot);
      g.matrix.set(R[0][0], R[0][1], R[0][2], c[0], R[1][0], R[1][1], R[1][2], c[1], R[2][0], R[2][1], R[2][2], c[2], 0, 0, 0, 1);
      g.matrixWorldNeedsUpdate = true;
    }
    straight.forEach((l, i) => {
      const a = endAt(l.a, f), b = endAt(l.b, f);
      linkPos.set(a, 6 * i);
      linkPos.set(l.kind === 'pin' || l.kind === 'rod' || l.kind === 'dashpot' ? b : a, 6 * i + 3);
      if (jointMarks[i]) jointMarks[i].position.set(...(l.kind === 'pin' || l.kind === 'rod' ? b : a));
      if (l.axis && l.a.body !== undefined) {
        // A joint's axis: a short line through its anchor.
        const R = D.bodies[l.a.body].rigid ? frameOf(D.bodies[l.a.body], f) : [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
        const w = [0, 1, 2].map(k => R[k][0] * l.axis[0] + R[k][1] * l.axis[1] + R[k][2] * l.axis[2]);
        const h = 0.04 * size;
        linkPos.set([a[0] - h * w[0], a[1] - h * w[1], a[2] - h * w[2]], 6 * i);
        linkPos.set([a[0] + h * w[0], a[1] + h * w[1], a[2] + h * w[2]], 6 * i + 3);
      }
    });
    linkGeo.attributes.position.needsUpdate = true;
    springs.forEach((l, i) => coil(coils[i], endAt(l.a, f), endAt(l.b, f)));
    for (const g of traces) g.setDrawRange(0, f + 1);
  }

  // Plots of the outputs (and the energy), a cursor at the current time.
  const plots = [];
  const series = D.outputs.names.map((name, j) => ({ name, v: f => outputs[f * nOut + j] }));
  if (D.energy) series.push({ name: 'energy', v: f => D.energy[f] });
  const side = document.getElementById('plots');
  for (const s of series.slice(0, 8)) {
    const box = document.createElement('div');
    box.className = 'plot';
    const label = document.createElement('div');
    label.className = 'plot-label';
    box.appendChild(label);
    const canvas = document.createElement('canvas');
    canvas.width = 260; canvas.height = 90;
    box.appendChild(canvas);
    side.appendChild(box);
    let mn = Infinity, mx = -Infinity;
    for (let f = 0; f < F; f++) { const v = s.v(f); if (isFinite(v)) { mn = Math.min(mn, v); mx = Math.max(mx, v); } }
    if (!(mx > mn)) { const m = isFinite(mn) ? mn : 0; mn = m - 1; mx = m + 1; }
    plots.push({ s, canvas, label, mn, mx });
  }
  const t0 = times[0], t1 = times[F - 1] > t0 ? times[F - 1] : t0 + 1;
  function drawPlots(f) {
    for (const p of plots) {
      const c = p.canvas.getContext('2d'), W = c.canvas.width, H = c.canvas.height;
      c.clearRect(0, 0, W, H);
      const X = t => 4 + (W - 8) * (t - t0) / (t1 - t0), Y = v => H - 4 - (H - 8) * (v - p.mn) / (p.mx - p.mn);
      c.strokeStyle = '#c5cad3'; c.beginPath(); c.moveTo(4, Y(p.mn)); c.lineTo(W - 4, Y(p.mn)); c.stroke();
      c.strokeStyle = '#2f6fb3'; c.lineWidth = 1.5; c.beginPath();
      for (let k = 0; k < F; k++) { const v = p.s.v(k); if (k === 0) c.moveTo(X(times[k]), Y(v)); else c.lineTo(X(times[k]), Y(v)); }
      c.stroke();
      c.strokeStyle = '#d0632b'; c.beginPath(); c.moveTo(X(times[f]), 0); c.lineTo(X(times[f]), H); c.stroke();
      p.label.textContent = `${p.s.name} = ${fmt(p.s.v(f))}   [${fmt(p.mn)} … ${fmt(p.mx)}]`;
    }
  }
  function fmt(v) {
    if (!isFinite(v)) return String(v);
    const a = Math.abs(v);
    return a !== 0 && (a < 1e-3 || a >= 1e5) ? v.toExponential(3) : (+v.toPrecision(5)).toString();
  }

  // Time line: slider, events, play, speed.
  const slider = document.getElementById('slider');
  slider.max = String(F - 1);
  const marks = document.getElementById('marks');
  for (const e of D.events) {
    const m = document.createElement('div');
    m.className = 'event';
    m.style.left = `${100 * (e.t - t0) / (t1 - t0)}%`;
    m.title = `${e.name} at t = ${fmt(e.t)}`;
    marks.appendChild(m);
  }
  document.getElementById('events').textContent = D.events.length
    ? `events: ${D.events.slice(0, 12).map(e => `${e.name} at ${fmt(e.t)}`).join(', ')}${D.events.length > 12 ? ` (and ${D.events.length - 12} more)` : ''}` : '';
  const clock = document.getElementById('clock');
  const playButton = document.getElementById('play');
  const speedSelect = document.getElementById('speed');
  let frame = 0, playing = false, simTime = t0, last = 0;
  // Playback rate: the run in about 20 s of wall time at 1× unless it is shorter than a minute.
  const base = (t1 - t0) > 60 || (t1 - t0) < 2 ? (t1 - t0) / 20 : 1;
  function frameAt(t) {
    let a = 0, b = F - 1;
    while (a < b) { const m = (a + b + 1) >> 1; if (times[m] <= t) a = m; else b = m - 1; }
    return a;
  }
  function show(f) {
    frame = Math.max(0, Math.min(F - 1, f));
    slider.value = String(frame);
    place(frame);
    drawPlots(frame);
    clock.textContent = `t = ${fmt(times[frame])} s   step ${steps[frame]}   frame ${frame + 1}/${F}`;
    render();
  }
  function render() {
    renderer.render(scene, camera);
    status.frame = frame;
    status.t = times[frame];
    status.slider = { value: Number(slider.value), max: Number(slider.max) };
    status.playing = playing;
    camera.updateMatrixWorld();
    const vp = new T.Matrix4().multiplyMatrices(camera.projectionMatrix, camera.matrixWorldInverse);
    const rect = renderer.domElement.getBoundingClientRect();
    status.viewport = [window.innerWidth, window.innerHeight];
    status.camera = { matrix: vp.elements.slice(), left: rect.left, top: rect.top, width: rect.width, height: rect.height };
    status.background = [BACKGROUND >> 16, (BACKGROUND >> 8) & 255, BACKGROUND & 255];
    document.getElementById('lieflow-status').textContent = JSON.stringify(status);
  }
  function resize() {
    const w = view.clientWidth, h = view.clientHeight;
    renderer.setSize(w, h);
    if (planar) {
      const half = 0.6 * Math.max(hi[0] - lo[0], (hi[1] - lo[1]) * w / h, 1e-9 * size) || 1;
      camera.left = -half; camera.right = half;
      camera.top = half * h / w; camera.bottom = -half * h / w;
    } else {
      camera.aspect = w / h;
    }
    camera.updateProjectionMatrix();
    render();
  }
  function tick(now) {
    if (!playing) return;
    const dt = last ? (now - last) / 1000 : 0;
    last = now;
    simTime += dt * base * Number(speedSelect.value);
    if (simTime >= times[F - 1]) {
      if (document.getElementById('loop').checked) simTime = t0;
      else { simTime = times[F - 1]; playing = false; playButton.textContent = '▶'; }
    }
    show(frameAt(simTime));
    if (playing) requestAnimationFrame(tick);
  }
  function play(on) {
    playing = on;
    playButton.textContent = on ? '❚❚' : '▶';
    if (on) {
      if (frame >= F - 1) simTime = t0; else simTime = times[frame];
      last = 0;
      requestAnimationFrame(tick);
    }
    render();
  }
  playButton.addEventListener('click', () => play(!playing));
  document.getElementById('fit').addEventListener('click', () => { controls.reset(); render(); });
  slider.addEventListener('input', () => { simTime = times[Number(slider.value)]; show(Number(slider.value)); });
  window.addEventListener('keydown', e => {
    if (e.key === ' ') { play(!playing); e.preventDefault(); }
    if (e.key === 'ArrowRight') show(frame + 1);
    if (e.key === 'ArrowLeft') show(frame - 1);
    if (e.key === 'r') { controls.reset(); render(); }
  });
  window.addEventListener('resize', resize);
  resize();
  // `#frame=N` (or `last`) and `#play` in the address: where the page opens (for tests and links).
  const hash = new URLSearchParams(location.hash.slice(1));
  const want = hash.get('frame');
  show(want === 'last' ? F - 1 : Number(want) || 0);
  status.ready = true;
  // Milliseconds from the page's navigation to the first frame drawn.
  status.loadMs = Math.round(performance.now());
  render();
  if (hash.has('play')) play(true);
})();
