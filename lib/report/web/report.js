// report.js — renders modal's HTML report from its two JSON blocks
// (#modal-data: the results; #modal-drawing: points, segments and mode
// displacements, or null). Inlined by lib/report/html.cpp after uPlot.
// Views of mode shapes are drawn by hand on a canvas: an orthographic
// projection of points and segments is a few lines, and no plotting library
// draws an animated, orbitable 3-D stick figure (docs/design.md, "HTML reports").
(function () {
  'use strict';
  var data = JSON.parse(document.getElementById('modal-data').textContent);
  var drawing = JSON.parse(document.getElementById('modal-drawing').textContent);
  var root = document.getElementById('report');
  var status = document.getElementById('report-status');
  var plots = 0, views = [], frames = 0;
  var state = { playing: true, amplitude: 0.15, time: 0 };

  function el(tag, attributes, children) {
    var e = document.createElement(tag);
    for (var k in attributes || {}) e.setAttribute(k, attributes[k]);
    (children || []).forEach(function (c) { e.appendChild(typeof c === 'string' ? document.createTextNode(c) : c); });
    return e;
  }
  // Numbers are the CSV's text (17 digits); shown to 6, the full value in data-v.
  function number(text) {
    if (text === '' || text === null || text === undefined) return '—';
    var x = Number(text);
    if (!isFinite(x)) return String(text);
    return x === 0 ? '0' : Math.abs(x) >= 1e-4 && Math.abs(x) < 1e7 ? String(Number(x.toPrecision(6))) : x.toExponential(5);
  }
  function table(headers, rows, id, numericColumns) {
    var head = el('tr', {}, headers.map(function (h) { return el('th', {}, [h]); }));
    var body = rows.map(function (row) {
      return el('tr', {}, row.map(function (cell, i) {
        if (numericColumns && numericColumns.indexOf(i) >= 0) return el('td', { 'data-v': cell, 'class': 'num' }, [number(cell)]);
        return el('td', {}, [String(cell)]);
      }));
    });
    var attributes = id ? { id: id } : {};
    return el('table', attributes, [el('thead', {}, [head]), el('tbody', {}, body)]);
  }
  function section(title, children) {
    var s = el('section', {}, [el('h2', {}, [title])].concat(children));
    root.appendChild(s);
    return s;
  }

  // --- scene, parameters, equilibrium, stability -------------------------------
  section('Scene', [
    el('p', {}, ['Scene file: ', el('code', {}, [data.scene])]),
    data.parameters.length ? table(['parameter', 'value'], data.parameters, 'parameters', [1]) : el('p', {}, ['No parameters.'])
  ]);
  var verdict = el('p', { id: 'stability', 'class': data.unstable ? 'verdict unstable' : 'verdict stable' },
                   [(data.unstable ? 'Unstable: ' : '') + data.stability.charAt(0).toUpperCase() + data.stability.slice(1) + '.']);
  var coordinates = data.coordinates.map(function (c) { return [c[0], c[2], c[1]]; });
  var eq = data.equilibrium;
  var shownNote = data.coordinate_count > data.coordinates.length
    ? [el('p', { 'class': 'note' }, ['The first ' + data.coordinates.length + ' of ' + data.coordinate_count + ' coordinates are listed (the CSV and JSON files have all).'])] : [];
  section('Stability', [verdict]);
  section('Equilibrium', [
    table(['quantity', 'value'], [['potential V (J)', eq.potential], ['relative residual', eq.residual],
      ['residual norm', eq.residual_norm], ['Newton iterations', String(eq.iterations)]], 'equilibrium', [1]),
    coordinates.length > 12
      ? el('details', {}, [el('summary', {}, [data.coordinate_count + ' coordinates']), table(['coordinate', 'kind', 'value'], coordinates, 'coordinates', [2])])
      : table(['coordinate', 'kind', 'value'], coordinates, 'coordinates', [2])
  ].concat(shownNote));

  // --- the mode table -------------------------------------------------------
  var numeric = [1, 2, 3, 4, 5, 6, 8, 9];
  section('Modes', [
    el('p', {}, ['Solver: ' + data.solver + '. ω² in rad²/s², σ and ω in rad/s, f in Hz, T in s; error_estimate is the ' +
      'estimated error of the eigenvalue, residual_bound the rigorous bound of what the eigen-solver left.']),
    table(data.columns, data.modes, 'modes-table', numeric)
  ].concat(data.notes.length ? [el('ul', { 'class': 'notes' }, data.notes.map(function (n) { return el('li', {}, [n]); }))] : []));

  // --- mode views -------------------------------------------------------------
  var controls = null;
  if (drawing && drawing.modes.length) {
    var play = el('button', { id: 'play', type: 'button' }, ['Pause']);
    play.addEventListener('click', function () {
      state.playing = !state.playing;
      play.textContent = state.playing ? 'Pause' : 'Play';
    });
    var amplitude = el('input', { id: 'amplitude', type: 'range', min: '0', max: '0.5', step: '0.01', value: String(state.amplitude) });
    amplitude.addEventListener('input', function () { state.amplitude = Number(amplitude.value); drawAll(); });
    controls = el('div', { 'class': 'controls' }, [play, el('label', {}, [' amplitude ', amplitude]),
      el('span', { 'class': 'hint' }, [drawing.dimensions === 3 ? ' Drag a view to turn it.' : ''])]);
  }
  var modesSection = section('Mode shapes', controls ? [controls] : []);
  if (drawing && drawing.note) modesSection.appendChild(el('p', { 'class': 'note' }, [drawing.note + '.']));
  if (drawing) modesSection.appendChild(el('p', {}, ['Each view shows the mode\'s linearized motion superposed on the ' +
    'equilibrium (grey), in the ' + (drawing.dimensions === 2 ? 'plane ' + 'xyz'[drawing.plane[0]] + 'xyz'[drawing.plane[1]] :
    'orthographic 3-D view') + '; the amplitude is a fraction of the scene\'s size.']));

  function bars(target, names, seriesList, title) {
    // Grouped bars: series k at x = i + offset_k; names label the integers.
    var count = seriesList.length, width = 0.8 / count;
    var x = [], ys = seriesList.map(function () { return []; });
    names.forEach(function (_, i) {
      seriesList.forEach(function (s, k) {
        x.push(i - 0.4 + width * (k + 0.5));
        ys.forEach(function (y, j) { y.push(j === k ? s.values[i] : null); });
      });
    });
    var colors = ['#3465a4', '#cc5500', '#4e9a06'];
    var options = {
      title: title, width: Math.min(760, 120 + 40 * names.length * count), height: 260,
      scales: { x: { time: false, range: [-0.6, names.length - 0.4] },
                y: { range: function (u, min, max) { return [Math.min(0, min), Math.max(0, max) || 1]; } } },
      legend: { show: count > 1, live: false },
      cursor: { show: false },
      axes: [{ splits: function () { return names.map(function (_, i) { return i; }); },
               values: function (u, splits) { return splits.map(function (v) { return names[v] === undefined ? '' : names[v]; }); },
               rotate: names.length > 6 ? -40 : 0, size: names.length > 6 ? 90 : 40 }, {}],
      series: [{}].concat(seriesList.map(function (s, k) {
        return { label: s.label, stroke: colors[k], fill: colors[k] + 'aa', spanGaps: false,
                 paths: uPlot.paths.bars({ size: [0.9 / count, 60], align: 0 }), points: { show: false } };
      }))
    };
    new uPlot(options, [x].concat(ys), target);
    plots++;
  }

  function modeView(container, entry) {
    var canvas = el('canvas', { width: '420', height: '320', 'class': 'view', 'data-mode': String(entry.mode) });
    container.appendChild(canvas);
    var view = { canvas: canvas, u: entry.displacement, yaw: 0.6, pitch: 0.4 };
    if (drawing.dimensions === 3) {
      var dragging = null;
      canvas.addEventListener('pointerdown', function (e) { dragging = [e.clientX, e.clientY]; canvas.setPointerCapture(e.pointerId); });
      canvas.addEventListener('pointerup', function () { dragging = null; });
      canvas.addEventListener('pointermove', function (e) {
        if (!dragging) return;
        view.yaw += (e.clientX - dragging[0]) * 0.01;
        view.pitch = Math.max(-1.5, Math.min(1.5, view.pitch + (e.clientY - dragging[1]) * 0.01));
        dragging = [e.clientX, e.clientY];
        draw(view);
      });
    }
    views.push(view);
    draw(view);
  }

  // The scene's size and centre, for the scale of views and displacements.
  var P = drawing ? drawing.points : [], n = P.length / 3, centre = [0, 0, 0], size = 0;
  if (n) {
    for (var a = 0; a < 3; a++) {
      var lo = Infinity, hi = -Infinity;
      for (var i = 0; i < n; i++) { lo = Math.min(lo, P[3 * i + a]); hi = Math.max(hi, P[3 * i + a]); }
      centre[a] = (lo + hi) / 2; size = Math.max(size, hi - lo);
    }
    if (!(size > 0)) size = 1;
  }
  // World point → canvas: the 2-D plane's axes, or the orbit's orthographic projection.
  function projector(view) {
    var w = view.canvas.width, h = view.canvas.height, s = 0.7 * Math.min(w, h) / size;
    if (drawing.dimensions === 2) {
      var ax = drawing.plane[0], ay = drawing.plane[1];
      return function (p) { return [w / 2 + s * (p[ax] - centre[ax]), h / 2 - s * (p[ay] - centre[ay])]; };
    }
    var cy = Math.cos(view.yaw), sy = Math.sin(view.yaw), cp = Math.cos(view.pitch), sp = Math.sin(view.pitch);
    return function (p) {  // z up; turn about z by yaw, tilt about the screen's horizontal by pitch
      var x = p[0] - centre[0], y = p[1] - centre[1], z = p[2] - centre[2];
      var xr = cy * x - sy * y, yr = sy * x + cy * y;
      return [w / 2 + s * xr, h / 2 - s * (cp * z - sp * yr)];
    };
  }
  function draw(view) {
    var g = view.canvas.getContext('2d'), project = projector(view);
    var k = state.amplitude * size * Math.sin(state.time);
    g.clearRect(0, 0, view.canvas.width, view.canvas.height);
    function pass(scale, color, radius) {
      var q = new Array(n);
      for (var i = 0; i < n; i++)
        q[i] = project([P[3 * i] + scale * view.u[3 * i], P[3 * i + 1] + scale * view.u[3 * i + 1], P[3 * i + 2] + scale * view.u[3 * i + 2]]);
      g.strokeStyle = color; g.fillStyle = color; g.lineWidth = 1.5;
      g.beginPath();
      var S = drawing.segments;
      for (var j = 0; j < S.length; j += 2) { g.moveTo(q[S[j]][0], q[S[j]][1]); g.lineTo(q[S[j + 1]][0], q[S[j + 1]][1]); }
      g.stroke();
      if (n <= 5000) for (var m = 0; m < n; m++) g.fillRect(q[m][0] - radius, q[m][1] - radius, 2 * radius, 2 * radius);
    }
    pass(0, '#bbbbbb', 2);
    pass(k, '#204a87', 3);
    frames++;
  }
  function drawAll() { views.forEach(draw); }

  var energy = data.energy;
  data.modes.forEach(function (row, index) {
    var mode = index + 1;
    var box = el('div', { 'class': 'mode', id: 'mode-' + mode }, [el('h3', {}, ['Mode ' + mode + ': ' + row[7] +
      (row[4] !== '' ? ', f = ' + number(row[4]) + ' Hz' : '') + ', ω² = ' + number(row[1]) + ' rad²/s²'])]);
    modesSection.appendChild(box);
    var entry = drawing ? drawing.modes.filter(function (m) { return m.mode === mode; })[0] : null;
    if (entry) modeView(box, entry);
    else if (data.shapes && data.shapes[index]) {
      var target = el('div', { 'class': 'plot' });
      box.appendChild(target);
      bars(target, data.shape_coordinates.slice(0, data.shapes[index].length), [{ label: 'shape', values: data.shapes[index] }],
           'Shape (real part' + (data.coordinate_count > data.shapes[index].length ? ', first ' + data.shapes[index].length + ' coordinates' : '') + ')');
    }
    var e = energy ? energy.modes[index] : null;
    if (e) {
      var names = [], kinetic = [], potential = [];
      function add(list, which) {
        (list || []).forEach(function (pair) {
          var i = names.indexOf(pair[0]);
          if (i < 0) { names.push(pair[0]); kinetic.push(null); potential.push(null); i = names.length - 1; }
          (which === 0 ? kinetic : potential)[i] = pair[1];
        });
      }
      add(e.kinetic, 0); add(e.potential, 1);
      var target2 = el('div', { 'class': 'plot energy' });
      box.appendChild(target2);
      bars(target2, names, [{ label: 'kinetic share', values: kinetic }, { label: 'potential share', values: potential }],
           'Energy shares' + (e.potential ? '' : ' (potential shares not defined: a zero mode)'));
      if (energy.directions.length) {
        box.appendChild(table(['direction', 'participation factor', 'effective mass (kg)', 'cumulative fraction'],
          energy.directions.map(function (d, j) {
            return [d.name, String(e.participation_factor[j]), String(e.effective_mass[j]), String(e.cumulative_fraction[j])];
          }), null, [1, 2, 3]));
      }
    }
  });
  if (energy && energy.directions.length)
    modesSection.appendChild(el('p', {}, ['Movable mass per direction: ' + energy.directions.map(function (d) {
      return d.name + ' ' + number(String(d.movable_mass)) + ' kg'; }).join(', ') + '.']));

  // --- animation and the status line --------------------------------------------
  function report() {
    var errors = window.modalErrors || [];
    status.setAttribute('data-done', '1');
    status.setAttribute('data-errors', String(errors.length));
    status.setAttribute('data-plots', String(plots));
    status.setAttribute('data-views', String(views.length));
    status.setAttribute('data-frames', String(frames));
    status.textContent = 'Rendered: ' + plots + ' plots, ' + views.length + ' animated views, ' + frames +
      ' frames drawn, ' + errors.length + ' script errors' + (errors.length ? ': ' + errors.join('; ') : '') + '.';
    status.className = errors.length ? 'status bad' : 'status';
  }
  report();
  if (views.length) {
    var last = Date.now();
    setInterval(function () {
      var now = Date.now();
      if (state.playing) { state.time += (now - last) / 1000 * 2 * Math.PI * 0.8; drawAll(); }
      last = now;
      report();
    }, 40);
  }
})();
