// report.js — renders modal's HTML reports from their two JSON blocks
// (#modal-data: the results, with the report's kind: analyze, sweep, map,
// amplitude, simulate or equilibria; #modal-drawing: points, segments and
// mode displacements, or null). Inlined by lib/report/html.cpp after uPlot.
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
  var drawAll = function () {};

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

  // === analyze: scene, parameters, equilibrium, stability, modes ====================
  function renderAnalysis() {
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
      var view = { canvas: canvas, u: entry.displacement, v: entry.displacement_imag || null, yaw: 0.6, pitch: 0.4 };
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
      // Re(J φ e^{it}): J Re φ cos t − J Im φ sin t (complex shapes of first-order problems).
      var kc = state.amplitude * size * Math.cos(state.time), ks = view.v ? -state.amplitude * size * Math.sin(state.time) : 0;
      g.clearRect(0, 0, view.canvas.width, view.canvas.height);
      function at(i, a, moving) {
        var x = P[3 * i + a];
        if (moving) { x += kc * view.u[3 * i + a]; if (view.v) x += ks * view.v[3 * i + a]; }
        return x;
      }
      function pass(moving, color, radius) {
        var q = new Array(n);
        for (var i = 0; i < n; i++) q[i] = project([at(i, 0, moving), at(i, 1, moving), at(i, 2, moving)]);
        g.strokeStyle = color; g.fillStyle = color; g.lineWidth = 1.5;
        g.beginPath();
        var S = drawing.segments;
        for (var j = 0; j < S.length; j += 2) { g.moveTo(q[S[j]][0], q[S[j]][1]); g.lineTo(q[S[j + 1]][0], q[S[j + 1]][1]); }
        g.stroke();
        if (n <= 5000) for (var m = 0; m < n; m++) g.fillRect(q[m][0] - radius, q[m][1] - radius, 2 * radius, 2 * radius);
      }
      pass(false, '#bbbbbb', 2);
      pass(true, '#204a87', 3);
      frames++;
    }
    drawAll = function () { views.forEach(draw); };

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
        var imag = data.shapes_imag ? data.shapes_imag[index] : null;
        var series = [{ label: 'real part', values: data.shapes[index] }];
        if (imag) series.push({ label: 'imaginary part', values: imag });
        bars(target, data.shape_coordinates.slice(0, data.shapes[index].length), series,
             'Shape' + (imag ? ' (complex: the motion is Re(φ e^{iωt}))' : '') +
             (data.coordinate_count > data.shapes[index].length ? ', first ' + data.shapes[index].length + ' coordinates' : ''));
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

  }
  // === plots and tables shared by the study reports ===========================
  var palette = ['#3465a4', '#cc5500', '#4e9a06', '#75507b', '#c4a000', '#a40000', '#06989a', '#555753', '#ce5c00', '#204a87'];
  var classColors = ['#8ae234', '#4e9a06', '#fce94f', '#ef2929', '#ad7fa8'];  // stable … flutter; failed: grey
  function fmt(x) { return number(String(x)); }
  function p(text) { return el('p', {}, [text]); }
  function note(text) { return el('p', { 'class': 'note' }, [text]); }
  function plotBox(parent) { var d = el('div', { 'class': 'plot' }); parent.appendChild(d); return d; }
  // A CSV writer's rows as a table: every cell keeps the field in data-v; numbers are shown to 6 digits.
  function csvTable(t, id) {
    var head = el('tr', {}, t.columns.map(function (h) { return el('th', {}, [h]); }));
    var body = t.rows.map(function (row) {
      return el('tr', {}, row.map(function (cell) {
        var numeric = cell !== '' && isFinite(Number(cell));
        return el('td', numeric ? { 'data-v': cell, 'class': 'num' } : { 'data-v': cell }, [numeric ? number(cell) : cell]);
      }));
    });
    var parts = [el('table', { id: id, 'class': 'csv' }, [el('thead', {}, [head]), el('tbody', {}, body)])];
    if (t.total_rows > t.rows.length)
      parts.push(note('The first ' + t.rows.length + ' of ' + t.total_rows + ' rows are shown; the CSV file has all.'));
    return el('div', { 'class': 'table-box' }, parts);
  }
  // Axis numbers: short, and in exponent form where uPlot's would round to 0 (log axes, small values).
  function tickLabels(u, splits) {
    return splits.map(function (v) {
      if (v === null || v === undefined) return '';
      if (v === 0) return '0';
      var a = Math.abs(v);
      return a < 1e-3 || a >= 1e6 ? v.toExponential(Number(v.toExponential(0)) === v ? 0 : 1) : String(Number(v.toPrecision(6)));
    });
  }
  // Series with their own x values on one uPlot chart: the x values of all
  // series merged and sorted, each series null where it has no point (lines
  // span the gaps). o: title, xlabel, ylabel, series [{label, x, y, color,
  // points, line, dash}], xlog, ylog, xrange, yrange, marks (vertical lines
  // {x, error, label}), levels (horizontal lines {y, label}), bands ({from,
  // to, color} shaded), draw (a further draw hook).
  function xyPlot(target, o) {
    var all = [];
    o.series.forEach(function (s, k) {
      s.x.forEach(function (x, i) {
        var y = s.y[i];
        if (x === null || y === null || !isFinite(x) || !isFinite(y)) return;
        if ((o.xlog && x <= 0) || (o.ylog && y <= 0)) return;
        all.push([x, k, y]);
      });
    });
    all.sort(function (a, b) { return a[0] - b[0]; });
    var xs = all.map(function (a) { return a[0]; });
    var ys = o.series.map(function () { var a = new Array(all.length); for (var i = 0; i < a.length; i++) a[i] = null; return a; });
    all.forEach(function (a, i) { ys[a[1]][i] = a[2]; });
    function vertical(u, x, color, dash, label, row) {
      var px = u.valToPos(x, 'x', true), g = u.ctx, top = u.bbox.top, h = u.bbox.height;
      if (!isFinite(px)) return;
      g.save(); g.strokeStyle = color; g.lineWidth = 1.5 * devicePixelRatio; g.setLineDash(dash);
      g.beginPath(); g.moveTo(px, top); g.lineTo(px, top + h); g.stroke();
      if (label) { g.fillStyle = color; g.font = (11 * devicePixelRatio) + 'px sans-serif'; g.fillText(label, px + 4 * devicePixelRatio, top + (14 + 14 * row) * devicePixelRatio); }
      g.restore();
    }
    var hooks = {
      drawClear: [function (u) {
        (o.bands || []).forEach(function (b) {
          var a = u.valToPos(b.from, 'x', true), c = u.valToPos(b.to, 'x', true);
          u.ctx.save(); u.ctx.fillStyle = b.color; u.ctx.fillRect(Math.min(a, c), u.bbox.top, Math.abs(c - a), u.bbox.height); u.ctx.restore();
        });
      }],
      draw: [function (u) {
        (o.marks || []).forEach(function (m, i) {
          vertical(u, m.x, m.color || '#a40000', [6, 4], m.label, i);
          // ± error as a bar under the label, where it fits in the plot (the text gives it in any case).
          if (m.error > 0 && m.x - m.error >= u.scales.x.min && m.x + m.error <= u.scales.x.max) {
            var a = u.valToPos(m.x - m.error, 'x', true), c = u.valToPos(m.x + m.error, 'x', true);
            var y = u.bbox.top + (20 + 14 * i) * devicePixelRatio, g = u.ctx;
            g.save();
            g.strokeStyle = m.color || '#a40000'; g.lineWidth = 2 * devicePixelRatio; g.beginPath();
            g.moveTo(a, y); g.lineTo(c, y); g.moveTo(a, y - 3 * devicePixelRatio); g.lineTo(a, y + 3 * devicePixelRatio);
            g.moveTo(c, y - 3 * devicePixelRatio); g.lineTo(c, y + 3 * devicePixelRatio); g.stroke(); g.restore();
          }
        });
        (o.levels || []).forEach(function (l) {
          var py = u.valToPos(l.y, 'y', true), g = u.ctx;
          if (!isFinite(py) || py < u.bbox.top || py > u.bbox.top + u.bbox.height) return;
          g.save(); g.strokeStyle = '#555'; g.lineWidth = devicePixelRatio; g.setLineDash([3, 3]);
          g.beginPath(); g.moveTo(u.bbox.left, py); g.lineTo(u.bbox.left + u.bbox.width, py); g.stroke();
          if (l.label) {  // at the right end, clear of the axis
            g.fillStyle = '#555'; g.font = (11 * devicePixelRatio) + 'px sans-serif'; g.textAlign = 'right';
            g.fillText(l.label, u.bbox.left + u.bbox.width - 4 * devicePixelRatio, py - 3 * devicePixelRatio);
          }
          g.restore();
        });
        if (o.draw) o.draw(u);
      }]
    };
    var options = {
      title: o.title, width: o.width || 760, height: o.height || 320, hooks: hooks,
      scales: { x: { time: false, distr: o.xlog ? 3 : 1, log: 10, range: o.xrange }, y: { distr: o.ylog ? 3 : 1, log: 10, range: o.yrange } },
      axes: [{ label: o.xlabel, values: tickLabels }, { label: o.ylabel, size: 70, values: tickLabels }],
      legend: { show: o.legend !== false, live: false },
      cursor: { drag: { x: false, y: false } },
      series: [{ label: o.xlabel }].concat(o.series.map(function (s, k) {
        var color = s.color || palette[k % palette.length];
        return { label: s.label, stroke: color, spanGaps: true, dash: s.dash,
                 width: s.line === false ? 0 : 1.5, paths: s.line === false ? function () { return null; } : undefined,
                 points: { show: s.points === true, size: 5, fill: color, stroke: color } };
      }))
    };
    // Log axes: ticks and grid lines at powers of ten only (at most about 8).
    function decades(scale) {
      return function (u) {
        var lo = Math.ceil(Math.log10(u.scales[scale].min) - 1e-9), hi = Math.floor(Math.log10(u.scales[scale].max) + 1e-9), a = [];
        var step = Math.max(1, Math.ceil((hi - lo + 1) / 8));
        for (var e = lo; e <= hi; e += step) a.push(Math.pow(10, e));
        return a;
      };
    }
    if (o.xlog) options.axes[0].splits = decades('x');
    if (o.ylog) options.axes[1].splits = decades('y');
    if (o.xinteger)  // ticks at whole numbers only (equilibrium numbers)
      options.axes[0].splits = function (u) {
        var lo = Math.ceil(u.scales.x.min), hi = Math.floor(u.scales.x.max), step = Math.max(1, Math.ceil((hi - lo + 1) / 15)), a = [];
        for (var v = lo; v <= hi; v += step) a.push(v);
        return a;
      };
    if (o.xrange === undefined) delete options.scales.x.range;
    if (o.yrange === undefined) delete options.scales.y.range;
    new uPlot(options, [xs].concat(ys), target);
    plots++;
  }
  // Shaded parameter intervals around points of an unstable class (divergence, flutter).
  function unstableBands(x, stability) {
    var bands = [];
    for (var i = 0; i < x.length; i++) {
      if (stability[i] !== 3 && stability[i] !== 4) continue;
      var lo = i > 0 ? (x[i - 1] + x[i]) / 2 : x[i], hi = i + 1 < x.length ? (x[i] + x[i + 1]) / 2 : x[i];
      bands.push({ from: lo, to: hi, color: stability[i] === 3 ? 'rgba(239,41,41,0.10)' : 'rgba(117,80,123,0.12)' });
    }
    return bands;
  }
  function notesList(notes) {
    return notes && notes.length ? [el('ul', { 'class': 'notes' }, notes.map(function (n) { return el('li', {}, [n]); }))] : [];
  }

  // === sweep: branches, root locus, Campbell diagram, critical values ===========
  function renderSweep() {
    var P = data.parameter, x = data.x;
    section('Sweep', [
      el('p', {}, ['Scene file: ', el('code', {}, [data.scene])]),
      p(data.points_total + ' values of ' + P + ' from ' + fmt(x[0]) + ' to ' + fmt(x[x.length - 1]) +
        (data.coordinates ? ', ' + data.coordinates + (data.coordinates === 1 ? ' coordinate' : ' coordinates') : '') + '; ' + data.evaluations +
        ' evaluations in all (grid and refinements).' +
        (data.stride > 1 ? ' Plots show every ' + data.stride + 'th point.' : ''))
    ].concat(notesList(data.notes)));
    var critical = data.critical;
    section('Critical values', [
      critical.length
        ? el('ul', { id: 'critical' }, critical.map(function (c) { return el('li', {}, [c.text]); }))
        : p('No change of stability class between ' + fmt(x[0]) + ' and ' + fmt(x[x.length - 1]) + '.'),
      p('Each value is refined to a relative width of ' + data.tolerance.toExponential(0) +
        '; ± is half the final bracket, a bound on the distance to the change of class.'),
      csvTable(data.critical_table, 'critical-table')
    ]);
    var marks = critical.map(function (c) { return { x: c.value, error: c.error, label: P + ' = ' + fmt(c.value) + ' (' + c.kind + ')' }; });
    var bands = unstableBands(x, data.stability);
    var s = section('Branches', [p('Each mode against ' + P + ' (the lowest ' + data.branches.length +
      ' modes). Shaded: divergence (red), flutter (violet); dashed: the critical values.')]);
    function branchPlot(field, title, ylabel) {
      xyPlot(plotBox(s), { title: title, xlabel: P, ylabel: ylabel, marks: marks, bands: bands, levels: [{ y: 0 }],
        series: data.branches.map(function (b) { return { label: 'mode ' + b.mode, x: x, y: b[field], points: x.length < 60 }; }) });
    }
    if (data.symmetric) branchPlot('omega2', 'ω² against ' + P, 'ω² [rad²/s²]');
    else {
      branchPlot('growth_rate', 'Re s (growth rate σ) against ' + P, 'σ [1/s]');
      branchPlot('omega', 'Im s (frequency ω) against ' + P, 'ω [rad/s]');
    }
    // The root locus: s = σ + iω of each mode at every point, and its mirror σ − iω.
    var locus = section('Root locus', [p('The eigenvalues s = σ + iω of each mode at every value of ' + P +
      ' in the complex plane, with their conjugates; the right half plane is unstable.')]);
    // Re s spans at least a tenth of the largest |Im s| either side of the axis (an undamped locus lies on it).
    var re = [0], im = [0];
    data.branches.forEach(function (b) {
      b.growth_rate.forEach(function (v) { if (v !== null) re.push(v); });
      b.omega.forEach(function (v) { if (v !== null) im.push(Math.abs(v)); });
    });
    var reach = 0.1 * Math.max.apply(null, im) || 1, lo = Math.min.apply(null, re), hi = Math.max.apply(null, re);
    xyPlot(plotBox(locus), { title: 'Root locus', xlabel: 'Re s [1/s]', ylabel: 'Im s [rad/s]', height: 380,
      xrange: [Math.min(lo - 0.05 * (hi - lo), -reach), Math.max(hi + 0.05 * (hi - lo), reach)],
      draw: function (u) {  // the imaginary axis
        var px = u.valToPos(0, 'x', true);
        if (px >= u.bbox.left && px <= u.bbox.left + u.bbox.width) {
          u.ctx.save(); u.ctx.strokeStyle = '#888'; u.ctx.beginPath(); u.ctx.moveTo(px, u.bbox.top); u.ctx.lineTo(px, u.bbox.top + u.bbox.height); u.ctx.stroke(); u.ctx.restore();
        }
      },
      series: data.branches.map(function (b) {
        return { label: 'mode ' + b.mode, x: b.growth_rate.concat(b.growth_rate),
                 y: b.omega.concat(b.omega.map(function (w) { return w === null ? null : -w; })), points: true, line: false };
      }) });
    if (data.frame_rate) {
      var campbell = section('Campbell diagram', [p('The frequency of each mode against the rotation rate |Ω| of the scene\'s frame, ' +
        'which ' + P + ' sets. The dashed line ω = |Ω| is excitation once per revolution; a mode crossing it is in resonance there.')]);
      var rates = data.frame_rate;
      var series = data.branches.map(function (b) { return { label: 'mode ' + b.mode, x: rates, y: b.omega, points: rates.length < 60 }; });
      var top = Math.max.apply(null, rates.filter(function (r) { return r !== null; }));
      series.push({ label: '1× (ω = |Ω|)', x: [0, top], y: [0, top], color: '#888', dash: [6, 4] });
      xyPlot(plotBox(campbell), { title: 'Campbell diagram', xlabel: '|Ω| [rad/s]', ylabel: 'ω [rad/s]', series: series });
    }
    if (data.convergence) {
      var c = data.convergence;
      var conv = section('Convergence', [p('The distance of each mode\'s ω from its Richardson-extrapolated value ω∞ against ' + P +
        ', on logarithmic axes: the slope is −p, the observed order of convergence.')]);
      var convSeries = c.modes.filter(function (m) { return m.asymptotic; }).map(function (m) {
        return { label: 'mode ' + m.mode + ' (p = ' + m.order.toFixed(3) + ')', x: m.n,
                 y: m.omega.map(function (w) { return w === null ? null : Math.abs(w - m.value); }), points: true };
      });
      if (convSeries.length)
        xyPlot(plotBox(conv), { title: '|ω − ω∞| against ' + P, xlabel: P, ylabel: '|ω − ω∞| [rad/s]', xlog: true, ylog: true, series: convSeries });
      c.modes.filter(function (m) { return !m.asymptotic; }).forEach(function (m) {
        conv.appendChild(note('Mode ' + m.mode + ': no extrapolation: ' + m.reason + '.'));
      });
      conv.appendChild(csvTable(c.table, 'extrapolation-table'));
    }
    section('Points', [el('details', {}, [el('summary', {}, ['Every point and mode (as the CSV)']), csvTable(data.table, 'points-table')])]);
  }

  // === stability map: the grid coloured by class, the boundary drawn ===============
  function renderMap() {
    var X = data.x.values, Y = data.y.values, nx = X.length, ny = Y.length, cells = data.cells;
    var counts = [0, 0, 0, 0, 0], failed = 0;
    cells.forEach(function (c) { if (c < 0) failed++; else counts[c]++; });
    section('Stability map', [
      el('p', {}, ['Scene file: ', el('code', {}, [data.scene])]),
      p(data.x.name + ': ' + nx + ' values from ' + fmt(X[0]) + ' to ' + fmt(X[nx - 1]) + '; ' + data.y.name + ': ' + ny +
        ' values from ' + fmt(Y[0]) + ' to ' + fmt(Y[ny - 1]) + '. Each grid point is a cell in the colour of its class; ' +
        'black lines separate cells of different classes (the stability boundary, to within a cell).')
    ].concat(data.failures.map(function (f) { return note('Failed at ' + f); })));
    // A cell spans halfway to its neighbours.
    function edges(v) {
      var e = [];
      for (var i = 0; i <= v.length; i++) {
        if (i === 0) e.push(v[0] - (v.length > 1 ? (v[1] - v[0]) / 2 : 0.5));
        else if (i === v.length) e.push(v[i - 1] + (v.length > 1 ? (v[i - 1] - v[i - 2]) / 2 : 0.5));
        else e.push((v[i - 1] + v[i]) / 2);
      }
      return e;
    }
    var ex = edges(X), ey = edges(Y);
    var xr = [Math.min(ex[0], ex[nx]), Math.max(ex[0], ex[nx])], yr = [Math.min(ey[0], ey[ny]), Math.max(ey[0], ey[ny])];
    var s = section('Map', []);
    var legend = el('p', { 'class': 'legend' }, data.class_names.map(function (name, k) {
      return el('span', {}, [el('span', { 'class': 'swatch', style: 'background:' + classColors[k] }), ' ' + name + ' (' + counts[k] + ')  ']);
    }).concat(failed ? [el('span', {}, [el('span', { 'class': 'swatch', style: 'background:#bbb' }), ' failed (' + failed + ')'])] : []));
    s.appendChild(legend);
    xyPlot(plotBox(s), { title: 'Stability classes', xlabel: data.x.name, ylabel: data.y.name, height: 460, legend: false,
      xrange: xr, yrange: yr,
      series: [{ label: 'grid', x: xr, y: yr, line: false, points: false }],
      draw: function (u) {
        var g = u.ctx;
        g.save();
        g.beginPath(); g.rect(u.bbox.left, u.bbox.top, u.bbox.width, u.bbox.height); g.clip();
        function px(v) { return u.valToPos(v, 'x', true); }
        function py(v) { return u.valToPos(v, 'y', true); }
        for (var j = 0; j < ny; j++) for (var i = 0; i < nx; i++) {
          var c = cells[j * nx + i];
          g.fillStyle = c < 0 ? '#bbb' : classColors[c];
          var x0 = px(ex[i]), x1 = px(ex[i + 1]), y0 = py(ey[j]), y1 = py(ey[j + 1]);
          g.fillRect(Math.min(x0, x1), Math.min(y0, y1), Math.abs(x1 - x0) + 0.5, Math.abs(y1 - y0) + 0.5);
        }
        g.strokeStyle = '#000'; g.lineWidth = 2 * devicePixelRatio; g.beginPath();
        for (var jj = 0; jj < ny; jj++) for (var ii = 0; ii < nx; ii++) {
          var here = cells[jj * nx + ii];
          if (ii + 1 < nx && cells[jj * nx + ii + 1] !== here) { g.moveTo(px(ex[ii + 1]), py(ey[jj])); g.lineTo(px(ex[ii + 1]), py(ey[jj + 1])); }
          if (jj + 1 < ny && cells[(jj + 1) * nx + ii] !== here) { g.moveTo(px(ex[ii]), py(ey[jj + 1])); g.lineTo(px(ex[ii + 1]), py(ey[jj + 1])); }
        }
        g.stroke();
        g.restore();
      } });
    section('Grid', [el('details', {}, [el('summary', {}, ['Every grid point (as the CSV)']), csvTable(data.table, 'map-table')])]);
  }

  // === amplitude: the period and the departure from the linear frequency ===========
  function renderAmplitude() {
    var unit = data.unit, a = data.amplitude;
    section('Mode ' + data.mode, [
      el('p', {}, ['Scene file: ', el('code', {}, [data.scene])]),
      p('Linear frequency ω_lin = ' + fmt(data.omega_linear) + ' rad/s (ω² = ' + fmt(data.omega2) + ' rad²/s²). The mode is released ' +
        'from rest at the equilibrium plus the amplitude times its shape, whose largest component \'' + data.coordinate +
        '\' moves by the amplitude [' + unit + ']; the nonlinear equations are integrated (' + data.evaluations +
        ' motions, rk8pd at tolerance ' + data.tolerance + ') and the period measured.')
    ]);
    var thresholds = data.thresholds;
    var rows = thresholds.map(function (t) {
      return [(100 * t.level) + ' %', t.reached ? String(t.amplitude) : '', t.reached && !t.note ? String(t.error) : '', t.note || ''];
    });
    section('Departure amplitudes', [
      el('ul', { id: 'thresholds' }, thresholds.map(function (t) {
        var level = (100 * t.level) + ' %';
        return el('li', {}, [t.reached && !t.note ? 'The frequency departs by ' + level + ' at amplitude ' + fmt(t.amplitude) + ' ± ' +
          Number(t.error).toPrecision(2) + ' ' + unit + '.' : 'Departure ' + level + ': ' + t.note + '.']);
      })),
      table(['level', 'amplitude [' + unit + ']', '± error [' + unit + ']', 'note'], rows, 'thresholds-table', [1, 2])
    ]);
    var marks = thresholds.filter(function (t) { return t.reached && t.amplitude !== null; }).map(function (t) {
      return { x: t.amplitude, error: t.error, label: (100 * t.level) + ' %', color: '#a40000' };
    });
    var s = section('Against amplitude', [p('Circles: measured amplitudes; dashed: where the departure reaches each level. Amplitudes ' +
      'on a logarithmic axis; where the motion left the well there is no point.')]);
    xyPlot(plotBox(s), { title: 'Period ratio T/T_lin', xlabel: 'amplitude [' + unit + ']', ylabel: 'T / T_lin', xlog: true, marks: marks,
      levels: [{ y: 1 }], series: [{ label: 'T / T_lin', x: a, y: data.period_ratio, points: true }] });
    xyPlot(plotBox(s), { title: 'Departure |ω/ω_lin − 1|', xlabel: 'amplitude [' + unit + ']', ylabel: '|ω/ω_lin − 1|', xlog: true, ylog: true,
      marks: marks, levels: thresholds.map(function (t) { return { y: t.level, label: (100 * t.level) + ' %' }; }),
      series: [{ label: '|ω/ω_lin − 1|', x: a, y: data.departure, points: true },
               { label: 'spread of the periods', x: a, y: data.spread, points: true, line: false, color: '#888' }] });
    section('Scan', [csvTable(data.table, 'scan-table')]);
  }

  // === simulate: the coordinates and the energy error against time =================
  function renderSimulation() {
    var S = data.summary;
    section('Simulation', [
      el('p', {}, ['Scene file: ', el('code', {}, [data.scene])]),
      table(['quantity', 'value'], [
        ['duration [s]', String(S.duration)], ['output samples', String(data.samples)], ['steps (rk8pd)', String(S.steps)],
        ['rejected steps', String(S.rejected_steps)], ['evaluations', String(S.evaluations)], ['tolerance', String(S.tolerance)],
        ['energy at the start E0 [J]', String(S.energy_start)], ['energy at the end [J]', String(S.energy_end)],
        ['work of non-conservative forces W [J]', String(S.work_end)], ['energy scale [J]', String(S.energy_scale)],
        ['max |E − E0 − W| / scale', String(S.max_energy_error)]], 'summary-table', [1]),
      p(S.conservative ? 'The scene is conservative: the energy is conserved, and its error measures the integration.'
                       : 'Dampers or follower loads do work W: the energy balance E − E0 − W = 0 measures the integration.')
    ].concat(notesList(data.notes)));
    var t = data.time;
    var s = section('Time series', data.per_bucket > 1
      ? [note('Each of the ' + t.length / 2 + ' time buckets of ' + data.per_bucket + ' samples is drawn by its minimum and maximum of every series (' +
              data.samples + ' samples in all).')] : []);
    if (data.coordinate_count > data.coordinates.length)
      s.appendChild(note('The first ' + data.coordinates.length + ' of ' + data.coordinate_count + ' coordinates are drawn.'));
    xyPlot(plotBox(s), { title: 'Coordinates', xlabel: 't [s]', ylabel: 'q [rad, m]',
      series: data.coordinates.map(function (name, i) { return { label: name, x: t, y: data.q[i] }; }) });
    xyPlot(plotBox(s), { title: 'Energy error (E − E0 − W) / scale', xlabel: 't [s]', ylabel: 'relative error', levels: [{ y: 0 }],
      series: [{ label: 'energy error', x: t, y: data.energy_error, color: '#a40000' }] });
    section('Samples', [p('Samples spread over the run, as the trajectory CSV has them.'), csvTable(data.table, 'samples-table')]);
  }

  // === equilibria: the list, each one's stability and frequency table ===============
  function renderEquilibria() {
    section('Scene', [
      el('p', {}, ['Scene file: ', el('code', {}, [data.scene])]),
      data.parameters.length ? table(['parameter', 'value'], data.parameters, 'parameters', [1]) : p('No parameters.')
    ]);
    var count = data.potential.length, index = [];
    for (var i = 0; i < count; i++) index.push(i + 1);
    var s = section('Equilibria', [p(count + ' equilibria found and analyzed. The potential V of each, green when stable (not divergence ' +
      'or flutter), red when unstable.')].concat(notesList(data.unanalyzed)));
    xyPlot(plotBox(s), { title: 'Potential energy of the equilibria', xlabel: 'equilibrium', ylabel: 'V [J]', xinteger: true,
      xrange: [0.5, count + 0.5],
      series: [{ label: 'stable', x: index, y: data.potential.map(function (v, k) { return data.stable[k] ? v : null; }), points: true, line: false, color: '#4e9a06' },
               { label: 'unstable', x: index, y: data.potential.map(function (v, k) { return data.stable[k] ? null : v; }), points: true, line: false, color: '#a40000' }] });
    s.appendChild(csvTable(data.table, 'equilibria-table'));
    var m = data.modes, columns = m.columns;
    var f = section('Frequencies', [p('Each equilibrium\'s modes, as the modes CSV of analyze has them (mode shapes are not animated here: ' +
      '`modal analyze --at` gives one equilibrium\'s full report).')]);
    for (var k = 1; k <= count; k++) {
      var rows = m.rows.filter(function (r) { return r[0] === String(k); });
      var box = el('details', k <= 3 ? { open: '' } : {}, [el('summary', {}, ['Equilibrium ' + k + ': ' + data.stability[k - 1]]),
        csvTable({ columns: columns, rows: rows, total_rows: rows.length }, 'modes-' + k)]);
      f.appendChild(box);
    }
    if (m.total_rows > m.rows.length) f.appendChild(note('The first ' + m.rows.length + ' of ' + m.total_rows + ' mode rows are shown.'));
  }

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
  var renderers = { analyze: renderAnalysis, sweep: renderSweep, map: renderMap, amplitude: renderAmplitude,
                    simulate: renderSimulation, equilibria: renderEquilibria };
  // Printed, folded tables of up to 200 rows are unfolded (longer ones would fill pages).
  window.addEventListener('beforeprint', function () {
    Array.prototype.forEach.call(document.querySelectorAll('details'), function (d) {
      if (d.querySelectorAll('tr').length <= 201) d.open = true;
    });
  });
  try { renderers[data.kind](); } catch (e) { window.modalErrors.push(String(e && e.stack || e)); }
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
