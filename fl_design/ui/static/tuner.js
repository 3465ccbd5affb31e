// fl-design tuner page: binds sliders to the server's /api/redraw; draws with Plotly.js
// (served by the tuner from the installed plotly package). Every URL is relative: the token
// is the first path segment of the page's own URL.
'use strict';
(function () {
  const N = 1000;  // slider positions
  const S = { controls: [], inflight: false, pending: false, lastInput: null,
              lastRedrawMs: null, lastServerMs: null, redraws: 0, drawn: null, bg: null };
  // read by the browser tests and verify/bench_ui.py: lastRedrawMs (input event to drawn),
  // lastFetchMs (request to JSON parsed), lastNetMs (its Resource Timing), lastHandlerMs (the
  // server's Server-Timing), lastServerMs / lastServerCpuMs (the redraw's wall and CPU time),
  // lastPlotMs (Plotly.react), lastPoints, lastBytes
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

  function responseTraces(d) {
    const line = (y, name, axis, extra) => Object.assign({ x: d.t, y, name, type: 'scatter',
      mode: 'lines', xaxis: 'x', yaxis: axis, hovertemplate: '%{y:.4g}' }, extra || {});
    return [line(d.r, 'r', 'y', { line: { dash: 'dash', color: '#888' } }),
            line(d.y, 'y', 'y', { line: { color: '#1f5fbf' } }),
            line(d.u, 'u', 'y2', { line: { color: '#c05010' } }),
            line(d.sigma, 'sigma', 'y3', { line: { color: '#2a8a2a' } }),
            line(d.sigmahat, 'sigmahat', 'y3', { line: { color: '#a02090', width: 1 } })];
  }
  const PLOT_CONFIG = { displayModeBar: false, responsive: true, scrollZoom: true };
  const responseLayout = {
    // the legend is HTML above the plot (#keys-response), drawn once: a Plotly legend is about
    // 50 more SVG nodes, laid out again at each move (and walked by every reader of the page)
    margin: { l: 55, r: 10, t: 10, b: 35 }, showlegend: false, hovermode: 'x unified',
    xaxis: { title: { text: 't (s)' }, anchor: 'y3' },
    yaxis: { domain: [0.68, 1], title: { text: 'y, r' } },
    yaxis2: { domain: [0.36, 0.63], title: { text: 'u' } },
    yaxis3: { domain: [0, 0.31], title: { text: 'sigma' } },
    uirevision: 'keep',
  };

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
      return Plotly.react('plot-response', responseTraces(d), responseLayout, PLOT_CONFIG)
        .then(() => {
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
