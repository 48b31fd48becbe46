// vmsim: the interactive 3-D view of simulate-part's report (report.html, section "3-D view").
// Reads window.vmsimDeviationMesh (3d/deviation_mesh.js, written by vmsim: app/report_3d.hpp)
// and draws each surface view's production surface coloured by its deviation from the
// reference surface with vtk.js (3d/vtk.js, the library's browser build). Drag: rotate; wheel:
// zoom; shift + drag: pan; a click without dragging: the point's deviation, position and
// program line. Everything it loads is in the result folder: it works offline, from file://.
// window.vmsimView3d tells the browser test (tests/browser/) whether the view came up.
(async function () {
  'use strict';
  const state = { ready: false, error: null, vertices: 0, triangles: 0, timings_ms: {},
                  markOutlines: 0, markLabels: 0 };
  const started = performance.now();
  window.vmsimView3d = state;

  const container = document.getElementById('view3d');
  const pickPanel = document.getElementById('view3d-pick');
  const viewSelect = document.getElementById('view3d-view');
  const resetButton = document.getElementById('view3d-reset');
  if (!container) return;

  function fail(message) {
    state.error = message;
    container.textContent = 'The 3-D view could not start: ' + message;
    container.classList.add('view3d-failed');
  }

  const data = window.vmsimDeviationMesh;
  if (typeof vtk === 'undefined') return fail('the viewer library (3d/vtk.js) did not load.');
  if (!data || data.format !== 1) return fail('its data (3d/deviation_mesh.js) did not load.');
  if (!data.views.length) return fail('the data holds no surface.');

  // Base64, then zlib (the browser's own DecompressionStream: no library, no network), to bytes.
  async function inflate(text) {
    const raw = atob(text);
    const bytes = new Uint8Array(raw.length);
    for (let i = 0; i < raw.length; ++i) bytes[i] = raw.charCodeAt(i);
    const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream('deflate'));
    return new Response(stream).arrayBuffer();
  }
  // The arrays are little-endian, as the machine that wrote them (x86 and ARM both are).
  async function decode(text, Type) { return new Type(await inflate(text)); }
  if (typeof DecompressionStream === 'undefined') {
    return fail('this browser is too old (it cannot unpack the data: a browser from 2023 or later can).');
  }

  // Moreland's cool-warm map, as the report's images: blue = gouge (negative), grey = 0,
  // red = excess material (positive).
  const coolWarm = [
    [-1.0, 0.230, 0.299, 0.754], [-0.5, 0.552, 0.690, 0.996], [0.0, 0.865, 0.865, 0.865],
    [0.5, 0.958, 0.604, 0.482], [1.0, 0.706, 0.016, 0.150]];

  function format(value, decimals) {
    const text = value.toFixed(decimals);
    return text === '-' + (0).toFixed(decimals) ? (0).toFixed(decimals) : text.replace('-', '\u2212');
  }

  const listedRanks = new Set(Array.from(document.querySelectorAll('a.show-in-3d'), (a) => Number(a.dataset.rank)));
  const labelLayer = document.createElement('div');
  labelLayer.className = 'view3d-labels';
  labelLayer.style.cssText = 'position:absolute;left:0;top:0;right:0;bottom:0;pointer-events:none;overflow:hidden';

  // Leader lines from a mark's point to its number, when the number had to move away.
  const svgNamespace = 'http://www.w3.org/2000/svg';
  const leaderLayer = document.createElementNS(svgNamespace, 'svg');
  leaderLayer.setAttribute('style', 'position:absolute;left:0;top:0;width:100%;height:100%;overflow:hidden');
  const leaderPath = document.createElementNS(svgNamespace, 'path');
  leaderPath.setAttribute('stroke', '#111');
  leaderPath.setAttribute('stroke-width', '1.5');
  leaderPath.setAttribute('fill', 'none');
  leaderLayer.appendChild(leaderPath);
  labelLayer.appendChild(leaderLayer);
  const scalarBarWidthPx = 130;

  // The rules of the report's images (viz/src/label_placement.cpp), in screen space (y down):
  // in the given order (deepest mark first), each number above-right of its point if the place
  // is free, else on rings of 4 px up to 80 px around it, 16 directions a ring; never over
  // another number (2 px apart) nor over another number's point, inside `area`; null when
  // there is no room (the number is left out). requests: [{x, y, width, height}] (px).
  function placeLabels(requests, area, maxDistance = 80, ringStep = 4, gap = 2) {
    const taken = [];
    const overlaps = (a, b) => a.x0 < b.x1 + gap && b.x0 < a.x1 + gap && a.y0 < b.y1 + gap && b.y0 < a.y1 + gap;
    const fits = (box, self) => {
      if (box.x0 < area.x0 || box.x1 > area.x1 || box.y0 < area.y0 || box.y1 > area.y1) return false;
      if (taken.some((other) => overlaps(box, other))) return false;
      return requests.every((r, k) => k === self || !(r.x >= box.x0 && r.x <= box.x1 && r.y >= box.y0 && r.y <= box.y1));
    };
    return requests.map((r, n) => {
      const w = r.width, h = r.height;
      let chosen = null;
      const usual = { x0: r.x + 4, y0: r.y - 2 - h, x1: r.x + 4 + w, y1: r.y - 2 };
      if (fits(usual, n)) chosen = usual;
      for (let ring = ringStep; !chosen && ring <= maxDistance + 1e-9; ring += ringStep) {
        for (let d = 0; d < 16 && !chosen; ++d) {
          const a = Math.PI / 4 + (d * Math.PI) / 8;  // from up-right, anticlockwise on the screen
          const cx = r.x + Math.cos(a) * (0.5 * w + ring);
          const cy = r.y - Math.sin(a) * (0.5 * h + ring);
          const box = { x0: cx - 0.5 * w, y0: cy - 0.5 * h, x1: cx + 0.5 * w, y1: cy + 0.5 * h };
          if (fits(box, n)) chosen = box;
        }
      }
      if (chosen) taken.push(chosen);
      return chosen;
    });
  }
  state.placeLabels = placeLabels;

  let renderWindow, renderer, interactor;
  try {
    const generic = vtk.Rendering.Misc.vtkGenericRenderWindow.newInstance({
      background: [1, 1, 1], listenWindowResize: true });
    generic.setContainer(container);
    generic.resize();
    renderWindow = generic.getRenderWindow();
    renderer = generic.getRenderer();
    interactor = generic.getInteractor();
    container.appendChild(labelLayer);
  } catch (error) {
    return fail('this browser could not open a WebGL canvas (' + error + ').');
  }

  const views = data.views.map((view) => ({ source: view, actor: null, polyData: null }));
  let shown = null;
  let scalarBar = null;
  let marker = null;

  async function unpackView(entry) {
    const view = entry.source;
    entry.positions = await decode(view.positions_mm, Float32Array);
    entry.deviation = await decode(view.deviation_um, Float32Array);
    entry.mark = await decode(view.mark, Int16Array);
    entry.block = await decode(view.block, view.block_bytes === 2 ? Uint16Array : Uint32Array);
  }

  function buildView(entry) {
    const view = entry.source;
    const positions = entry.positions;
    const deviation = entry.deviation;
    const [nu, nv] = view.cells;
    const valid = (i) => !Number.isNaN(deviation[i]);
    // Two triangles a cell of the grid; one where a corner has no surface.
    const cells = [];
    for (let j = 0; j + 1 < nv; ++j) {
      for (let i = 0; i + 1 < nu; ++i) {
        const a = i + nu * j, b = a + 1, c = a + 1 + nu, d = a + nu;
        const ok = [valid(a), valid(b), valid(c), valid(d)];
        const count = ok.filter(Boolean).length;
        if (count === 4) {
          cells.push(3, a, b, c, 3, a, c, d);
        } else if (count === 3) {
          const corners = [a, b, c, d].filter((_, k) => ok[k]);
          cells.push(3, corners[0], corners[1], corners[2]);
        }
      }
    }
    // Vertices without surface still need finite coordinates (no triangle uses them): those of
    // a vertex that has one, so that they do not widen the bounds the camera is fitted to.
    const first = deviation.findIndex((x) => !Number.isNaN(x));
    const points = Float32Array.from(positions, (x, k) => (Number.isNaN(x) ? (first < 0 ? 0 : positions[3 * first + (k % 3)]) : x));
    const colours = Float32Array.from(deviation, (x) => (Number.isNaN(x) ? 0 : x));
    const polyData = vtk.Common.DataModel.vtkPolyData.newInstance();
    polyData.getPoints().setData(points, 3);
    polyData.getPolys().setData(Uint32Array.from(cells));
    polyData.getPointData().setScalars(vtk.Common.Core.vtkDataArray.newInstance({
      name: 'deviation_um', values: colours, numberOfComponents: 1 }));
    const normals = vtk.Filters.Core.vtkPolyDataNormals.newInstance();
    normals.setInputData(polyData);
    const surface = normals.getOutputData();

    const half = Math.max(Math.abs(view.deviation_range_um[0]), Math.abs(view.deviation_range_um[1]),
                          2 * data.threshold_um, 1e-3);
    const lookup = vtk.Rendering.Core.vtkColorTransferFunction.newInstance();
    for (const [t, r, g, b] of coolWarm) lookup.addRGBPoint(t * half, r, g, b);
    const mapper = vtk.Rendering.Core.vtkMapper.newInstance({ interpolateScalarsBeforeMapping: true });
    mapper.setInputData(surface);
    mapper.setLookupTable(lookup);
    mapper.setScalarRange(-half, half);
    mapper.setScalarModeToUsePointData();
    mapper.setColorModeToMapScalars();
    const actor = vtk.Rendering.Core.vtkActor.newInstance();
    actor.setMapper(mapper);
    actor.getProperty().setAmbient(0.25);
    actor.getProperty().setDiffuse(0.75);
    entry.actor = actor;
    entry.lookup = lookup;
    entry.half = half;
    entry.cells = cells.length / 4;
    entry.polyData = polyData;
    entry.surface = surface;
  }

  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const unit = (a) => { const n = Math.hypot(...a); return a.map((x) => x / n); };

  // Seen from the front (-y), above, a little from the right (the part as on the machine), at
  // the distance where the surface's box just fills the view (vtk.js's resetCamera fits a
  // sphere: a long thin part would fill a fraction of the width).
  function placeCamera(entry) {
    const bounds = entry.actor.getBounds();
    const centre = [(bounds[0] + bounds[1]) / 2, (bounds[2] + bounds[3]) / 2, (bounds[4] + bounds[5]) / 2];
    const camera = renderer.getActiveCamera();
    const toCamera = unit([0.35, -1.0, 0.9]);
    const right = unit(cross([0, 0, 1], toCamera));
    const up = cross(toCamera, right);
    let width = 0, height = 0, depth = 0;
    for (let corner = 0; corner < 8; ++corner) {
      const p = [bounds[corner & 1], bounds[2 + ((corner >> 1) & 1)], bounds[4 + ((corner >> 2) & 1)]]
        .map((x, k) => x - centre[k]);
      width = Math.max(width, 2 * Math.abs(dot(p, right)));
      height = Math.max(height, 2 * Math.abs(dot(p, up)));
      depth = Math.max(depth, Math.abs(dot(p, toCamera)));
    }
    const box = container.getBoundingClientRect();
    const aspect = box.width / Math.max(box.height, 1);
    const halfAngle = (camera.getViewAngle() * Math.PI) / 360;
    const distance = depth + (0.55 * Math.max(height, width / aspect)) / Math.tan(halfAngle);
    camera.setFocalPoint(...centre);
    camera.setPosition(...centre.map((x, k) => x + toCamera[k] * distance));
    camera.setViewUp(...up);
    renderer.resetCameraClippingRange();
  }

  // The marks the page lists (its marks table's "3-D" links), drawn over the surface: each one's
  // outline (the border of the triangles whose three corners lie in it, lifted a little off the
  // surface towards the camera's side so that it is not hidden in it) and a label with its number
  // at its deepest point, kept beside the point as the view turns (vtk.js's pixel-space callback
  // gives the point's place on the canvas at every frame).

  function buildMarkOverlay(entry) {
    const listed = [];  // indices into data.marks of this view's listed marks
    data.marks.forEach((m, index) => {
      if (!m.speck && listedRanks.has(m.rank) && m.view === entry.source.id) listed.push(index);
    });
    entry.overlayActors = [];
    entry.labels = [];
    if (!listed.length) return;
    const wanted = new Map(listed.map((index) => [index, true]));
    const normals = entry.surface.getPointData().getNormals();
    const bounds = entry.actor.getBounds();
    const lift = 0.002 * Math.hypot(bounds[1] - bounds[0], bounds[3] - bounds[2], bounds[5] - bounds[4]);
    // Edges of the triangles wholly in one listed mark; those used once are its border.
    const edges = new Map();
    const cells = entry.polyData.getPolys().getData();
    for (let c = 0; c < cells.length; c += 4) {
      const a = cells[c + 1], b = cells[c + 2], d = cells[c + 3];
      const m = entry.mark[a];
      if (m < 0 || !wanted.has(m) || entry.mark[b] !== m || entry.mark[d] !== m) continue;
      for (const [p, q] of [[a, b], [b, d], [d, a]]) {
        const key = p < q ? p + ',' + q : q + ',' + p;
        edges.set(key, (edges.get(key) || 0) + 1);
      }
    }
    const points = [], lines = [];
    const index = new Map();
    const pointOf = (v) => {
      if (!index.has(v)) {
        const n = normals.getTuple(v);
        index.set(v, points.length / 3);
        for (let k = 0; k < 3; ++k) points.push(entry.positions[3 * v + k] + lift * n[k]);
      }
      return index.get(v);
    };
    for (const [key, uses] of edges) {
      if (uses !== 1) continue;
      const [p, q] = key.split(',').map(Number);
      lines.push(2, pointOf(p), pointOf(q));
    }
    if (lines.length) {
      const outline = vtk.Common.DataModel.vtkPolyData.newInstance();
      outline.getPoints().setData(Float32Array.from(points), 3);
      outline.getLines().setData(Uint32Array.from(lines));
      const mapper = vtk.Rendering.Core.vtkMapper.newInstance();
      mapper.setInputData(outline);
      const actor = vtk.Rendering.Core.vtkActor.newInstance();
      actor.setMapper(mapper);
      actor.getProperty().setColor(0.05, 0.05, 0.05);
      actor.getProperty().setLineWidth(2);
      actor.setPickable(false);
      entry.overlayActors.push(actor);
    }
    entry.outlinedMarks = new Set(Array.from(edges.keys(), (key) => entry.mark[Number(key.split(',')[0])])).size;
    // One label a mark at its deepest point; the callback places the labels at every frame.
    const anchors = [];
    for (const m of listed) {
      anchors.push(...data.marks[m].deepest_point_mm);
      const label = document.createElement('div');
      label.className = 'view3d-mark-label';
      label.dataset.rank = String(data.marks[m].rank);
      label.textContent = String(data.marks[m].rank);
      label.title = 'mark ' + data.marks[m].rank + ', ' + data.marks[m].kind + ', ' +
        format(data.marks[m].depth_um, 2) + ' \u00b5m deep';
      label.style.cssText = 'position:absolute;box-sizing:border-box;font:bold 12px sans-serif;' +
        'color:#111;background:rgba(255,255,255,0.8);border:1px solid #111;border-radius:3px;padding:0 3px;' +
        'white-space:nowrap;display:none';
      entry.labels.push(label);
    }
    const anchorData = vtk.Common.DataModel.vtkPolyData.newInstance();
    anchorData.getPoints().setData(Float32Array.from(anchors), 3);
    const pixelMapper = vtk.Rendering.Core.vtkPixelSpaceCallbackMapper.newInstance();
    pixelMapper.setInputData(anchorData);
    // Placed anew at every frame, in the canvas's CSS pixels (origin top left).
    pixelMapper.setCallback((coordinates, camera, aspect, depth, size) => {
      const ratio = window.devicePixelRatio || 1;
      const width = size[0] / ratio, height = size[1] / ratio;
      const requests = [], requested = [];
      coordinates.forEach(([x, y, z], k) => {
        const label = entry.labels[k];
        const inside = z > -1 && z < 1 && x >= 0 && y >= 0 && x <= size[0] && y <= size[1];
        if (!inside) return;
        if (!label.vmsimSize) {  // measured once, shown off-screen
          label.style.left = '-1000px';
          label.style.display = 'block';
          label.vmsimSize = [label.offsetWidth, label.offsetHeight];
        }
        requests.push({ x: x / ratio, y: (size[1] - y) / ratio, width: label.vmsimSize[0], height: label.vmsimSize[1] });
        requested.push(k);
      });
      // Clear of the colour bar (drawn by vtk.js at the right edge).
      const placed = placeLabels(requests, { x0: 0, y0: 0, x1: Math.max(0, width - scalarBarWidthPx), y1: height });
      const shownNow = new Set();
      const leaders = [];
      placed.forEach((box, n) => {
        if (!box) return;
        const k = requested[n];
        shownNow.add(k);
        const label = entry.labels[k];
        label.style.display = 'block';
        label.style.left = box.x0.toFixed(1) + 'px';
        label.style.top = box.y0.toFixed(1) + 'px';
        label.vmsimBox = box;
        label.vmsimAnchor = [requests[n].x, requests[n].y];
        // A leader line from the point to the box's nearest point, when the box is away from it.
        const nearX = Math.min(Math.max(requests[n].x, box.x0), box.x1);
        const nearY = Math.min(Math.max(requests[n].y, box.y0), box.y1);
        if (Math.hypot(nearX - requests[n].x, nearY - requests[n].y) > 6) {
          leaders.push('M' + requests[n].x.toFixed(1) + ' ' + requests[n].y.toFixed(1) + 'L' + nearX.toFixed(1) + ' ' + nearY.toFixed(1));
        }
      });
      entry.labels.forEach((label, k) => {
        if (!shownNow.has(k)) { label.style.display = 'none'; label.vmsimBox = null; }
      });
      leaderPath.setAttribute('d', leaders.join(''));
    });
    const anchorActor = vtk.Rendering.Core.vtkActor.newInstance();
    anchorActor.setMapper(pixelMapper);
    anchorActor.setPickable(false);
    entry.overlayActors.push(anchorActor);
  }

  function show(index) {
    const entry = views[index];
    if (!entry.actor) { buildView(entry); buildMarkOverlay(entry); }
    if (shown) {
      renderer.removeActor(shown.actor);
      for (const actor of shown.overlayActors) renderer.removeActor(actor);
    }
    shown = entry;
    renderer.addActor(entry.actor);
    for (const actor of entry.overlayActors) renderer.addActor(actor);
    labelLayer.replaceChildren(leaderLayer, ...entry.labels);
    leaderPath.setAttribute('d', '');
    if (scalarBar) renderer.removeActor(scalarBar);
    scalarBar = vtk.Rendering.Core.vtkScalarBarActor.newInstance();
    scalarBar.setScalarsToColors(entry.lookup);
    scalarBar.setAxisLabel('deviation [\u00b5m]');
    scalarBar.setDrawNanAnnotation(false);
    // Dark text: vtk.js draws it white, for a dark background.
    scalarBar.setAxisTextStyle({ fontColor: '#222', fontStyle: 'normal', fontSize: 16, fontFamily: 'sans-serif' });
    scalarBar.setTickTextStyle({ fontColor: '#222', fontStyle: 'normal', fontSize: 14, fontFamily: 'sans-serif' });
    renderer.addActor(scalarBar);
    if (marker) { renderer.removeActor(marker); marker = null; }
    placeCamera(entry);
    renderWindow.render();
    // The scale bar lays its labels out from the first frame's size: once more for them.
    requestAnimationFrame(() => renderWindow.render());
    state.vertices = entry.deviation.length;
    state.triangles = entry.cells;
    state.view = entry.source.id;
    state.markOutlines = entry.outlinedMarks || 0;
    state.markLabels = entry.labels.length;
  }

  // A small sphere at the picked vertex.
  function mark(point) {
    if (marker) renderer.removeActor(marker);
    const bounds = shown.actor.getBounds();
    const size = Math.hypot(bounds[1] - bounds[0], bounds[3] - bounds[2], bounds[5] - bounds[4]);
    const camera = renderer.getActiveCamera();
    const distance = Math.hypot(...camera.getPosition().map((x, k) => x - camera.getFocalPoint()[k]));
    const sphere = vtk.Filters.Sources.vtkSphereSource.newInstance({
      center: point, radius: Math.min(size / 150, distance / 120), thetaResolution: 16, phiResolution: 16 });
    const mapper = vtk.Rendering.Core.vtkMapper.newInstance();
    mapper.setInputConnection(sphere.getOutputPort());
    marker = vtk.Rendering.Core.vtkActor.newInstance();
    marker.setMapper(mapper);
    marker.getProperty().setColor(0.1, 0.1, 0.1);
    marker.setPickable(false);
    renderer.addActor(marker);
  }

  function describe(vertex) {
    const entry = shown;
    const p = [0, 1, 2].map((k) => entry.positions[3 * vertex + k]);
    const deviation = entry.deviation[vertex];
    const lines = [];
    const kind = deviation < -data.threshold_um ? ' (gouge)' : deviation > data.threshold_um ? ' (excess material)' : '';
    lines.push(['Deviation', format(deviation, 2) + ' \u00b5m' + kind]);
    lines.push(['Point (x, y, z)', '(' + p.map((x) => format(x, 3)).join(', ') + ') mm']);
    lines.push(['Surface view', entry.source.title]);
    const markIndex = entry.mark[vertex];
    let programLine = 0;
    if (markIndex >= 0) {
      const m = data.marks[markIndex];
      lines.push([m.speck ? 'In speck' : 'In mark', (m.speck ? '' : '#') + m.rank + ', ' + m.kind + ', ' +
                  format(m.depth_um, 2) + ' \u00b5m deep']);
      if (m.line > 0) {
        programLine = m.line;
        lines.push(['Program line (the mark\u2019s)', m.line + '  ' + m.block_text]);
      }
    }
    const blockIndex = entry.block[vertex];
    if (blockIndex > 0) {
      const [file, line, number, text] = blocks[blockIndex - 1];
      if (!programLine) programLine = line;
      const name = data.files[file] + ':' + line + (number >= 0 ? ' N' + number : '');
      lines.push(['Nearest programmed path', name + '  ' + text]);
    }
    pickPanel.replaceChildren();
    const table = document.createElement('table');
    for (const [name, value] of lines) {
      const row = table.insertRow();
      const th = document.createElement('th');
      th.textContent = name;
      row.appendChild(th);
      row.insertCell().textContent = value;
    }
    pickPanel.appendChild(table);
    pickPanel.dataset.deviationUm = deviation.toFixed(4);
    pickPanel.dataset.pointMm = p.map((x) => x.toFixed(4)).join(',');
    pickPanel.dataset.programLine = String(programLine);
    pickPanel.dataset.mark = markIndex >= 0 && !data.marks[markIndex].speck ? String(data.marks[markIndex].rank) : '';
  }

  // Display coordinates (device pixels, origin bottom left) to the nearest vertex of the cell hit.
  const picker = vtk.Rendering.Core.vtkCellPicker.newInstance();
  picker.setPickFromList(true);
  function pickAt(x, y) {
    picker.initializePickList();
    picker.addPickList(shown.actor);
    picker.pick([x, y, 0], renderer);
    const cell = picker.getCellId();
    if (cell === undefined || cell < 0 || picker.getActors().length === 0) {
      pickPanel.replaceChildren('No surface under the pointer: click on the surface.');
      delete pickPanel.dataset.deviationUm;
      return false;
    }
    const at = picker.getPickPosition();
    const cells = shown.polyData.getPolys().getData();
    let best = -1, bestDistance = Infinity;
    for (let k = 1; k <= 3; ++k) {
      const vertex = cells[4 * cell + k];
      const d = Math.hypot(...[0, 1, 2].map((c) => shown.positions[3 * vertex + c] - at[c]));
      if (d < bestDistance) { bestDistance = d; best = vertex; }
    }
    describe(best);
    mark([0, 1, 2].map((c) => shown.positions[3 * best + c]));
    renderWindow.render();
    return true;
  }

  // A click is a press and release within a few pixels (a drag rotates, as vtk.js does).
  let pressed = null;
  container.addEventListener('pointerdown', (event) => { pressed = [event.clientX, event.clientY]; });
  container.addEventListener('pointerup', (event) => {
    if (!pressed || event.button !== 0) return;
    const moved = Math.hypot(event.clientX - pressed[0], event.clientY - pressed[1]);
    pressed = null;
    if (moved > 4) return;
    const box = container.getBoundingClientRect();
    const ratio = window.devicePixelRatio || 1;
    pickAt((event.clientX - box.left) * ratio, (box.bottom - event.clientY) * ratio);
  });

  // Centres the view on a mark (the marks table's "3-D" links), about four widths of it across.
  function showMark(rank) {
    const index = data.marks.findIndex((m) => !m.speck && m.rank === rank);
    if (index < 0) return false;
    const m = data.marks[index];
    const viewIndex = views.findIndex((entry) => entry.source.id === m.view);
    if (viewIndex >= 0 && views[viewIndex] !== shown) {
      viewSelect.value = String(viewIndex);
      show(viewIndex);
    }
    const camera = renderer.getActiveCamera();
    const target = m.deepest_point_mm;
    // Seen along the surface's normal there (turned a little towards where the camera was, and
    // to the camera's side of the surface): a mark on a wall is not seen edge on.
    let nearest = 0, nearestDistance = Infinity;
    for (let i = 0; i < shown.deviation.length; ++i) {
      const d = Math.hypot(...[0, 1, 2].map((k) => shown.positions[3 * i + k] - target[k]));
      if (d < nearestDistance) { nearestDistance = d; nearest = i; }
    }
    const wasToCamera = camera.getDirectionOfProjection().map((x) => -x);
    let normal = shown.surface.getPointData().getNormals().getTuple(nearest);
    if (dot(normal, wasToCamera) < 0) normal = normal.map((x) => -x);
    const toCamera = unit(normal.map((x, k) => x + 0.6 * wasToCamera[k]));
    const width = 4;  // mm across
    const distance = width / 2 / Math.tan((camera.getViewAngle() * Math.PI) / 360);
    camera.setFocalPoint(...target);
    camera.setPosition(...target.map((x, k) => x + toCamera[k] * distance));
    camera.setViewUp(...(Math.abs(toCamera[2]) > 0.95 ? [0, 1, 0] : [0, 0, 1]));
    renderer.resetCameraClippingRange();
    renderWindow.render();
    return true;
  }

  let blocks = [];
  try {
    blocks = JSON.parse(new TextDecoder().decode(await inflate(data.blocks)));
    for (const entry of views) await unpackView(entry);
    state.timings_ms.unpack = performance.now() - started;
    data.views.forEach((view, index) => {
      const option = document.createElement('option');
      option.value = String(index);
      option.textContent = view.title;
      viewSelect.appendChild(option);
    });
    viewSelect.addEventListener('change', () => show(Number(viewSelect.value)));
    resetButton.addEventListener('click', () => { placeCamera(shown); renderWindow.render(); });
    for (const link of document.querySelectorAll('a.show-in-3d')) {
      link.addEventListener('click', () => showMark(Number(link.dataset.rank)));
    }
    show(0);
    state.timings_ms.first_frame = performance.now() - started;
  } catch (error) {
    return fail(String(error));
  }
  state.showMark = showMark;
  // For the browser test's crowded case: the camera moved towards its focal point (factor < 1:
  // away), then a frame.
  state.zoom = (factor) => {
    renderer.getActiveCamera().dolly(factor);
    renderer.resetCameraClippingRange();
    renderWindow.render();
  };
  state.ready = true;
})();
