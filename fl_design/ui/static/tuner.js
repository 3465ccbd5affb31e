// fl-design tuner page: binds sliders to the server's /api/redraw; draws the response with
// uPlot (static/, MIT) and the map with Plotly.js (served from the installed plotly package).
// Every URL is relative: the token is the first path segment of the page's own URL.
'use strict';
(function () {
  const N = 1000;  // slider positions
  const S = { controls: [], inflight: false, pending: false, lastInput: null,
              lastRedrawMs: null, lastServerMs: null, redraws: 0, drawn: null, bg: null };
  // read by the browser tests and verify/bench_ui.py: lastRedrawMs (input event to drawn),
  // lastFetchMs (request to JSON parsed), lastNetMs (its Resource Timing), lastHandlerMs (the
  // server's Server-Timing), lastServerMs / lastServerCpuMs (the redraw's wall and CPU time),
  // lastPlotMs (the response charts' redraw), lastPoints, lastBytes; response (the charts)
  window.flTuner = S;
  const $ = (id) => document.getElementById(id);

  function api(path, body) {
    const opts = body === undefined ? {} : { method: 'POST', body: JSON.stringify(body),
      headers: { 'Content-Type': 'application/json' } };
    return fetch(path, opts).then((r) => r.text().then((t) => ({ ok: r.ok, j: JSON.parse(t),
                                                                 bytes: t.length })));
  }
  function fmt(v, unit) {
    if (v === null || v === undefined) return 'none';
    if (v === 0) return '0' + (unit || '');
    const a = Math.abs(v);
    const s = (a >= 1e-2 && a < 1e4) ? String(+v.toPrecision(4)) : v.toExponential(2);
    return s + (unit || '');
  }
  function toValue(c, pos) {
    const p = pos / N;
    if (c.scale === 'linear') return c.min + (c.max - c.min) * p;
    if (c.scale === 'log0' && pos === 0) return 0;
    const lo = Math.log10(c.min), hi = Math.log10(c.max);
    return Math.pow(10, lo + (hi - lo) * p);
  }
  function toPos(c, v) {
    let p;
    if (c.scale === 'linear') p = (v - c.min) / (c.max - c.min);
    else if (v <= 0) p = 0;
    else p = (Math.log10(v) - Math.log10(c.min)) / (Math.log10(c.max) - Math.log10(c.min));
    return Math.round(N * Math.min(1, Math.max(0, p)));
  }

  function buildSliders(controls) {
    const box = $('sliders');
    controls.forEach((c) => {
      const div = document.createElement('div');
      div.className = 'slider';
      const label = document.createElement('label');
      label.htmlFor = 'slider-' + c.name;
      label.textContent = c.label + ' ';
      const val = document.createElement('span');
      val.className = 'value';
      val.id = 'value-' + c.name;
      label.appendChild(val);
      const input = document.createElement('input');
      Object.assign(input, { type: 'range', min: 0, max: N, step: 1, id: 'slider-' + c.name,
                             value: toPos(c, c.value) });
      input.setAttribute('aria-label', c.label);
      c.current = c.value;  // the exact value until the slider moves (positions are rounded)
      input.addEventListener('input', () => {
        S.lastInput = performance.now();
        c.current = toValue(c, +input.value);
        request();
      });
      div.appendChild(label);
      div.appendChild(input);
      box.appendChild(div);
      c.input = input;
    });
  }

  function collect() {
    const v = { gains: [] };
    S.controls.forEach((c) => {
      let x = c.current;
      if (c.name === 'gamma') x *= c.sign;
      if (/^k\d+$/.test(c.name)) v.gains.push(x); else v[c.name] = x;
    });
    return v;
  }

  function request() {
    if (S.inflight) { S.pending = true; return; }
    S.inflight = true;
    S.pending = false;
    const since = S.lastInput;
    const sent = performance.now();
    api('api/redraw', collect()).then(({ ok, j, bytes }) => {
      S.lastFetchMs = performance.now() - sent;
      S.lastBytes = bytes;
      netTiming();
      if (!ok || j.error) showError(j.error || 'the server refused the request');
      else return draw(j, since);
    }).catch((e) => showError('no answer from the tuner: ' + e))
      .finally(() => { S.inflight = false; if (S.pending) request(); });
  }

  // The last redraw request's network timing (Resource Timing, Server-Timing): how long the
  // answer took to arrive, apart from waiting for the page's main thread.
  function netTiming() {
    const all = performance.getEntriesByType('resource').filter((e) => e.name.endsWith('api/redraw'));
    const e = all[all.length - 1];
    performance.clearResourceTimings();
    if (!e) return;
    S.lastNetMs = e.responseEnd - e.startTime;
    const st = (e.serverTiming || []).find((x) => x.name === 'server');
    S.lastHandlerMs = st ? st.duration : null;
  }

  function showError(msg) {
    $('error').textContent = msg;
    $('status').textContent = 'not run';
  }

  const PLOT_CONFIG = { displayModeBar: false, responsive: true, scrollZoom: true };

  // --- the response: three uPlot charts (canvas), one x axis --------------------------------
  // uPlot redraws 5 traces of a few hundred points in 1-2 ms (setData on a canvas) where an SVG
  // figure of three subplots is laid out again in 30-40 ms: it is redrawn at every move.
  // Cursor and x zoom are shared (drag to zoom, double-click for the whole run); the legend
  // under each chart shows the values at the cursor. Plotly draws the map (it moves rarely).
  const CHARTS = [
    { label: 'y, r', series: [{ label: 'r', stroke: '#888', dash: [6, 4], width: 1.5 },
                              { label: 'y', stroke: '#1f5fbf', width: 2 }], cols: ['r', 'y'] },
    { label: 'u', series: [{ label: 'u', stroke: '#c05010', width: 2 }], cols: ['u'] },
    { label: 'sigma', series: [{ label: 'sigma', stroke: '#2a8a2a', width: 2 },
                               { label: 'sigmahat', stroke: '#a02090', width: 1 }],
      cols: ['sigma', 'sigmahat'] }];
  const R = { charts: null, zoom: null, syncing: false };
  const num = (u, v) => (v === null || v === undefined ? '-' : +v.toPrecision(4));

  function fullX(u) { const t = u.data[0]; return { min: t[0], max: t[t.length - 1] }; }
  function zoomAll(src, range) {  // one chart zoomed (or reset): the others follow
    R.zoom = range;
    if (R.syncing) return;
    R.syncing = true;
    R.charts.forEach((u) => {
      if (u !== src) u.setScale('x', range ? { min: range[0], max: range[1] } : fullX(u));
    });
    R.syncing = false;
  }
  function responseData(d, c) { return [d.t].concat(c.cols.map((k) => d[k])); }

  function makeCharts(d) {
    const box = $('plot-response');
    const last = CHARTS.length - 1;
    R.charts = CHARTS.map((c, i) => {
      const chart = new uPlot({
        width: box.clientWidth, height: i === last ? 200 : 150,
        scales: { x: { time: false } },
        cursor: { sync: { key: 'fl-response' }, drag: { x: true, y: false } },
        legend: { live: true },
        axes: [i === last ? { label: 't (s)', size: 50 }  // tick labels under the last only
          : { size: 8, values: (u, ticks) => ticks.map(() => '') },
               { label: c.label, size: 60 }],
        series: [{ label: 't (s)', value: num }].concat(
          c.series.map((x) => Object.assign({ value: num }, x))),
        hooks: { setSelect: [(u) => {
          if (u.select.width > 0) {
            zoomAll(u, [u.posToVal(u.select.left, 'x'),
                        u.posToVal(u.select.left + u.select.width, 'x')]);
          }
        }] },
      }, responseData(d, c), box);
      chart.over.addEventListener('dblclick', () => zoomAll(chart, null));  // uPlot resets it
      return chart;
    });
    window.addEventListener('resize', () => R.charts.forEach((u) => u.setSize({
      width: box.clientWidth, height: u.height })));
  }

  function drawResponse(d) {
    if (!R.charts) { makeCharts(d); return; }
    R.charts.forEach((u, i) => {
      u.setData(responseData(d, CHARTS[i]));
      if (R.zoom) u.setScale('x', { min: R.zoom[0], max: R.zoom[1] });  // the user's zoom stays
    });
  }
  S.response = R;  // read by the browser tests

  // The verdict's text is set as soon as the answer arrives; the traces are drawn in the next
  // animation frame (the usual place to draw).
  function draw(d, since) {
    const v = d.verdict;
    $('verdict').className = 'verdict ' + v.status;
    $('status').textContent = v.status;
    $('overshoot').textContent = fmt(v.overshoot, ' %');
    $('settling').textContent = v.settling_time === null ? 'not settled in ' + fmt(v.duration, ' s')
      : fmt(v.settling_time, ' s');
    $('verdict-text').textContent = v.text;
    $('noise-gain').textContent = d.noise_gain.text;
    $('error').textContent = '';
    showValues(d.values);
    S.drawn = d.values;
    S.lastServerMs = d.compute_ms;
    S.lastServerCpuMs = d.cpu_ms;
    return new Promise((resolve) => window.requestAnimationFrame(resolve)).then(() => {
      const t0 = performance.now();
      drawResponse(d);
      // uPlot draws in a microtask queued by setData: this one runs after it
      return Promise.resolve().then(() => {
        S.lastPlotMs = performance.now() - t0;
        S.lastPoints = d.t.length;
        S.redraws += 1;
        S.lastRedrawMs = since === null ? null : performance.now() - since;
        $('timing').textContent = (S.lastRedrawMs === null ? 'drawn' :
          'redrawn in ' + S.lastRedrawMs.toFixed(0) + ' ms') + ' (server ' +
          d.compute_ms.toFixed(0) + ' ms' + (d.kernel === 'compiled' ? ')' : ', ' + d.kernel + ')');
        window.requestAnimationFrame(drawMap);
      });
    });
  }

  function showValues(v) {
    S.controls.forEach((c) => {
      let x;
      if (/^k\d+$/.test(c.name)) x = v.gains[+c.name.slice(1) - 1];
      else x = c.name === 'gamma' ? Math.abs(v.gamma) : v[c.name];
      const unit = (c.name === 'eps' || c.name === 'T' || c.name === 'duration') ? ' s' : '';
      $('value-' + c.name).textContent = fmt(x, unit);
    });
  }

  // --- background results --------------------------------------------------------------------
  const COLORS = { converged: '#2a9d2a', converging: '#8fd18f', oscillating: '#f0a030',
                   undecided: '#bbbbbb', stalled: '#9a70c0', diverged: '#d03030',
                   solver_failed: '#222222' };
  function stateText(s) {
    if (!s) return '';
    if (s.state === 'ready') return '(ready, ' + fmt(s.seconds, ' s') + ')';
    if (s.state === 'stale') return '(for earlier controls; waiting to recompute)';
    if (s.state.startsWith('paused')) return '(' + s.state + ')';
    return '(' + s.state + '...)';
  }
  function usable(s) { return s && s.data && (s.state === 'ready' || s.state === 'stale'); }

  // One key of an HTML legend: a swatch (a line or a square, CSS) and its name.
  function key(name, style) {
    const span = document.createElement('span');
    span.className = 'key';
    const i = document.createElement('i');
    if (style.square) i.className = 'sq';
    if (style.glyph) {
      i.className = 'glyph';
      i.textContent = style.glyph;
    }
    Object.assign(i.style, style.glyph ? { color: style.color } : style.square ? { background: style.color } : {
      borderTopColor: style.color, borderTopStyle: style.dash || 'solid',
      borderTopWidth: (style.width || 2) + 'px' });
    span.appendChild(i);
    span.appendChild(document.createTextNode(name));
    return span;
  }

  const MAP_WAIT_MS = 400;
  function drawMap() {
    const bg = S.bg, v = S.drawn;
    if (!v) return;
    const g = Math.abs(v.gamma);
    // the background's part (heatmap, lines, legend) is rebuilt only when a result changed;
    // a move of eps or gamma only moves the design point and the bracket (Plotly.restyle)
    const part = (s) => s ? [s.state, s.seconds] : null;
    const sig = JSON.stringify(bg && [part(bg.map), part(bg.curve), part(bg.eps)]);
    if (sig === S.mapSig && S.mapMoving) {
      if (S.mapAt[0] === g && S.mapAt[1] === v.eps) return;
      S.mapAt = [g, v.eps];
      const idx = S.mapMoving, last = idx.length - 1;  // [the bracket,] the design point
      Plotly.restyle('plot-map', { x: idx.map((_, k) => (k === last ? [g] : [g, g])),
                                   y: idx.map((_, k) => (k === last ? [v.eps] : S.mapBracketY)) },
                     idx);
      return;
    }
    // a rebuild (tens of ms) waits while a slider moves: the response's redraws come first
    const still = S.lastInput === null ? Infinity : performance.now() - S.lastInput;
    if (still < MAP_WAIT_MS) {
      window.clearTimeout(S.mapTimer);
      S.mapTimer = window.setTimeout(drawMap, MAP_WAIT_MS - still);
      return;
    }
    S.mapSig = sig;
    S.mapAt = [g, v.eps];
    const traces = [], keys = [];
    const m = bg && bg.map;
    if (usable(m) && !m.data.error) {
      // one heatmap (a single image: a light DOM) coloured by status, on log axes
      const names = Object.keys(COLORS);
      const z = m.data.status.map((row) => row.map((code) => names.indexOf(m.data.labels[code] || 'undecided')));
      const scale = [];
      names.forEach((n, i) => { scale.push([i / names.length, COLORS[n]]); scale.push([(i + 1) / names.length, COLORS[n]]); });
      traces.push({ type: 'heatmap', x: m.data.gamma, y: m.data.eps, z, zmin: -0.5, zmax: names.length - 0.5,
                    colorscale: scale, showscale: false, opacity: m.state === 'stale' ? 0.35 : 0.85, xgap: 1, ygap: 1,
                    customdata: m.data.status.map((row) => row.map((code) => m.data.labels[code])),
                    hovertemplate: '%{customdata}<br>gamma %{x:.3g}<br>eps %{y:.3g}<extra></extra>' });
      const seen = new Set(m.data.status.flat().map((code) => m.data.labels[code]));
      names.filter((n) => seen.has(n)).forEach((n) => keys.push(key(n, { square: true, color: COLORS[n] })));
      const star = m.data.eps_star.map((s) => s.lower);
      traces.push({ x: m.data.gamma, y: star, name: 'empirical eps*', type: 'scatter',
                    mode: 'lines', line: { color: '#000', width: 2 } });
      keys.push(key('empirical eps*', { color: '#000' }));
    }
    const c = bg && bg.curve;
    if (usable(c) && !c.data.error) {
      const name = 'certified eps* (' + c.data.covers + ' b)';
      traces.push({ x: c.data.gamma, y: c.data.certified, name, type: 'scatter',
                    mode: 'lines+markers', line: { color: '#1f5fbf', dash: 'dot' } });
      keys.push(key(name, { color: '#1f5fbf', dash: 'dotted' }));
    }
    const e = bg && bg.eps;
    const moving = [];
    if (usable(e) && !e.data.error && e.data.brackets.length) {
      const b = e.data.brackets[e.data.brackets.length - 1];
      const name = 'bracket [certified, refuted] (' + b.covers + ' b)';
      S.mapBracketY = [b.certified, b.refuted === null ? b.certified : b.refuted];
      moving.push(traces.length);
      traces.push({ x: [g, g], y: S.mapBracketY, name, type: 'scatter', mode: 'lines+markers',
                    line: { color: '#a02090', width: 4 } });
      keys.push(key(name, { color: '#a02090', width: 4 }));
    }
    moving.push(traces.length);
    traces.push({ x: [g], y: [v.eps], name: 'design', type: 'scatter', mode: 'markers',
                  marker: { symbol: 'star', size: 16, color: '#ffd000', line: { color: '#000', width: 1 } } });
    keys.push(key('design', { glyph: '\u2605', color: '#e0b000' }));
    S.mapMoving = null;
    Plotly.react('plot-map', traces, {
      margin: { l: 55, r: 10, t: 10, b: 40 }, showlegend: false,
      xaxis: { type: 'log', title: { text: '|gamma|' }, dtick: 1, showgrid: false },
      yaxis: { type: 'log', title: { text: 'eps (s)' }, dtick: 1, showgrid: false },
      uirevision: 'keep' }, PLOT_CONFIG).then(() => { S.mapMoving = moving; });
    $('keys-map').replaceChildren(...keys);
  }

  function text(id, stage, render) {
    const el = $(id);
    if (!usable(stage)) { el.textContent = stage && stage.state === 'computing' ? 'computing...' : ''; return; }
    el.className = 'small' + (stage.state === 'stale' ? ' stale' : '');
    el.textContent = stage.data.error ? 'not available: ' + stage.data.error : render(stage.data);
  }

  function showBackground(bg) {
    const sig = JSON.stringify(Object.values(bg).map((s) => [s.state, s.seconds]));
    if (sig === S.bgSig) return;  // nothing new since the last poll
    S.bgSig = sig;
    S.bg = bg;
    $('state-map').textContent = stateText(bg.map);
    $('state-cert').textContent = stateText(bg.eps.state === 'ready' ? bg.eps : bg.gamma);
    $('state-margins').textContent = stateText(bg.margins);
    $('state-cost').textContent = stateText(bg.cost);
    $('map-words').textContent = usable(bg.map) && !bg.map.data.error ? 'runs of ' +
      fmt(bg.map.data.duration, ' s') + ' without noise; eps* = the largest eps with a converging run at each gamma' : '';
    const certs = $('certs');
    const parts = [];
    if (usable(bg.gamma)) parts.push(bg.gamma.data.error ? 'gamma: ' + bg.gamma.data.error :
      bg.gamma.data.text + '\nclass: ' + bg.gamma.data.words);
    else parts.push('gamma interval: ' + (bg.gamma.state === 'computing' ? 'computing...' : 'waiting'));
    if (usable(bg.eps)) {
      const d = bg.eps.data;
      parts.push(d.error ? 'eps*: ' + d.error : d.text + '\n' + d.brackets.map((b) =>
        b.covers + ' b: eps* in [' + fmt(b.certified) + ', ' + fmt(b.refuted) + '] (certified, refuted) for ' + b.words).join('\n'));
    } else parts.push('eps* bracket of the class: ' + (bg.eps.state === 'computing' ? 'computing (the longest: tens of seconds)...' : 'waiting'));
    if (usable(bg.curve)) parts.push(bg.curve.data.error ? 'eps* curve: ' + bg.curve.data.error :
      'certified eps* curve over gamma: ' + bg.curve.data.covers + ' b, for ' + bg.curve.data.words);
    certs.textContent = parts.join('\n\n');
    certs.className = 'small' + ((bg.eps.state === 'stale' || bg.gamma.state === 'stale') ? ' stale' : '');
    text('margins', bg.margins, (d) => d.rows.map((r) => r.text).join('\n') + '\n(' + d.words + ')');
    text('cost', bg.cost, (d) => d.text);
    drawMap();
  }

  function poll() {
    api('api/background').then(({ ok, j }) => { if (ok) showBackground(j); })
      .catch(() => {}).finally(() => window.setTimeout(poll, 800));
  }

  function save(what) {
    $('written').textContent = 'writing...';
    api('api/save', { what, values: collect() }).then(({ ok, j }) => {
      if (!ok) { $('written').textContent = 'not written: ' + j.error; return; }
      $('written').textContent = 'wrote ' + j.written + (j.files ? ' (' + j.files.length + ' files)' : '');
      if (what === 'snippet') {
        const area = $('snippet');
        area.value = j.text;
        area.hidden = false;
        if (navigator.clipboard) navigator.clipboard.writeText(j.text).then(() => {
          $('written').textContent += '; copied to the clipboard';
        }).catch(() => {});
      }
    });
  }

  function start() {
    api('api/init').then(({ ok, j }) => {
      if (!ok) { showError(j.error || 'cannot start'); return; }
      S.controls = j.controls;
      $('plant').textContent = j.plant + ' (' + j.source + '), relative degree ' + j.rho +
        (j.b_bounds ? ', b in [' + fmt(j.b_bounds[0]) + ', ' + fmt(j.b_bounds[1]) + ']' : '');
      if (j.plant_class) $('plant').textContent = 'class mode: ' + j.plant_class +
        ' | simulated: ' + j.plant;
      $('out').textContent = j.out;
      buildSliders(j.controls);
      $('save-toml').addEventListener('click', () => save('toml'));
      $('write-c').addEventListener('click', () => save('c'));
      $('copy-snippet').addEventListener('click', () => save('snippet'));
      request();
      poll();
    });
  }
  if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', start);
  else start();
})();
