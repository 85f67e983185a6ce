// aacmm view: the page. One renderer for every scene (format aacmm-view-1):
// live (frames and capture messages pushed over /ws), a session, a log, a
// verification or calibration report, or a self-contained HTML report (the
// scene embedded in <script id="aacmm-scene">). The page only reads: it never
// sends anything to the server. window.aacmmView.state is what it shows (tests
// and benchmarks read it).
"use strict";
(function () {
  const HISTORY = 3000;
  const T = { ARM: 0, TRAIL: 1, POINTS: 2, PLAIN: 3, FEATURES: 4 };
  const state = {
    // history: every frame received (device time, tip); latencies: per frame drawn, ms
    // from the host reading its sample to the page having drawn it.
    mode: null, scene: null, ready: false, readyAt: null, liveAt: null, connected: false, stopped: false,
    frames: 0, renders: 0, lastFrame: null, history: [], latencies: [], drawJs: [],
    capture: null, points: [], fits: 0, pointSeen: {}, captureLog: [], events: [], slowDraws: 0, fastErrors: [], errors: [], trail: [], trailMax: 0,
  };
  window.aacmmView = { state: state };
  const $ = (id) => document.getElementById(id);
  const esc = (s) => String(s == null ? "" : s).replace(/[&<>"']/g, (c) => (
    { "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" }[c]));
  const um = (mm) => (mm == null ? "" : (mm * 1000).toFixed(1));
  const mm4 = (v) => (v == null ? "" : Number(v).toFixed(4));
  const cols = (pts) => [pts.map((p) => (p ? p[0] : null)), pts.map((p) => (p ? p[1] : null)),
    pts.map((p) => (p ? p[2] : null))];

  // ------------------------------------------------------------ features
  function basis(n) {
    const a = Math.abs(n[0]) < 0.9 ? [1, 0, 0] : [0, 1, 0];
    const d = a[0] * n[0] + a[1] * n[1] + a[2] * n[2];
    let u = [a[0] - d * n[0], a[1] - d * n[1], a[2] - d * n[2]];
    const lu = Math.hypot(u[0], u[1], u[2]); u = u.map((x) => x / lu);
    const v = [n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2], n[0] * u[1] - n[1] * u[0]];
    return [u, v];
  }
  function circle(c, r, u, v, out) {
    for (let k = 0; k <= 48; k++) {
      const t = (2 * Math.PI * k) / 48, a = Math.cos(t) * r, b = Math.sin(t) * r;
      out.push([c[0] + a * u[0] + b * v[0], c[1] + a * u[1] + b * v[1], c[2] + a * u[2] + b * v[2]]);
    }
    out.push(null);
  }
  function sphere(c, r, out) {
    circle(c, r, [1, 0, 0], [0, 1, 0], out); circle(c, r, [1, 0, 0], [0, 0, 1], out);
    circle(c, r, [0, 1, 0], [0, 0, 1], out);
  }
  function featureLines(steps) {
    const out = [];
    let fits = 0;
    for (const st of steps || []) {
      const f = st.feature;
      if (!f) continue;
      fits += 1;
      if (f.kind === "sphere") sphere(f.center_mm, f.radius_mm, out);
      else if (f.kind === "spheres") f.spheres.forEach((s) => sphere(s.center_mm, s.radius_mm, out));
      else if (f.kind === "seat") {
        const c = f.center_mm, h = 6;
        for (const ax of [[h, 0, 0], [0, h, 0], [0, 0, h]]) {
          out.push([c[0] - ax[0], c[1] - ax[1], c[2] - ax[2]], [c[0] + ax[0], c[1] + ax[1], c[2] + ax[2]], null);
        }
      } else if (f.kind === "plane") {
        const [u, v] = basis(f.normal), p = f.point_mm, s = f.size_mm || [100, 100];
        const w = s[0] / 2, h = s[1] / 2;
        for (const [a, b] of [[-w, -h], [w, -h], [w, h], [-w, h], [-w, -h]]) {
          out.push([p[0] + a * u[0] + b * v[0], p[1] + a * u[1] + b * v[1], p[2] + a * u[2] + b * v[2]]);
        }
        out.push(null);
      } else if (f.kind === "lengths") {
        f.positions.forEach((q) => out.push(q.end_a_mm, q.end_b_mm, null));
      }
    }
    return { lines: out, fits: fits };
  }

  // ------------------------------------------------------------ the plot
  function pointTraces(points) {
    const withR = points.filter((p) => p.residual_mm != null);
    const plain = points.filter((p) => p.residual_mm == null);
    const text = (p) => `${esc(p.step)} ${esc(p.label)}` +
      (p.residual_mm == null ? "" : `<br>residual ${um(p.residual_mm)} um`);
    const r = withR.map((p) => Math.abs(p.residual_mm) * 1000);
    const cmax = Math.max(1, ...r);
    return [
      { x: cols(withR.map((p) => p.xyz)), text: withR.map(text), color: r, cmax: cmax },
      { x: cols(plain.map((p) => p.xyz)), text: plain.map(text) },
    ];
  }
  function traces() {
    const none = { x: [], y: [], z: [] };
    return [
      // The arm in one trace (links as the line; joints, and the tip last, as markers): a
      // live frame restyles two traces, the arm and the trail.
      { type: "scatter3d", mode: "lines+markers", name: "arm and tip", ...none, hoverinfo: "skip",
        line: { width: 9, color: "#57606a" }, marker: { size: [], color: [] } },
      { type: "scatter3d", mode: "lines", name: "trail", ...none, line: { width: 3, color: "#fb8500" }, hoverinfo: "skip" },
      { type: "scatter3d", mode: "markers", name: "points", ...none, text: [], hoverinfo: "text",
        marker: { size: 4, color: [], colorscale: "Portland", cmin: 0, cmax: 1,
          colorbar: { title: { text: "|residual| um" }, thickness: 12, len: 0.6 } } },
      { type: "scatter3d", mode: "markers", name: "points (no fit)", ...none, text: [], hoverinfo: "text",
        marker: { size: 4, color: "#8c959f" } },
      { type: "scatter3d", mode: "lines", name: "fitted features", ...none, line: { width: 2, color: "#2da44e" }, hoverinfo: "skip" },
    ];
  }
  function layout(reach) {
    const ax = (t) => {
      const a = { title: { text: t }, showspikes: false };
      if (reach) { a.range = [-reach, reach]; a.autorange = false; }
      return a;
    };
    return {
      margin: { l: 0, r: 0, t: 0, b: 0 }, showlegend: true, legend: { x: 0, y: 1 }, uirevision: "keep",
      scene: { xaxis: ax("x mm"), yaxis: ax("y mm"), zaxis: ax("z mm"),
        // live: the cube the arm can reach, seen from closer (the arm fills more of it)
        aspectmode: reach ? "cube" : "data",
        camera: { eye: reach ? { x: 0.95, y: -0.95, z: 0.6 } : { x: 1.5, y: -1.5, z: 0.9 } } },
    };
  }
  function setPoints(points, steps) {
    const [a, b] = pointTraces(points);
    const f = featureLines(steps);
    const [fx, fy, fz] = cols(f.lines);
    state.points = points;
    state.fits = f.fits;
    return Plotly.restyle("plot", {
      x: [a.x[0], b.x[0], fx], y: [a.x[1], b.x[1], fy], z: [a.x[2], b.x[2], fz],
      text: [a.text, b.text, null], "marker.color": [a.color, "#8c959f", null], "marker.cmax": [a.cmax, null, null],
    }, [T.POINTS, T.PLAIN, T.FEATURES]);
  }
  // The arm's polyline with a marker at each joint (blue) and at the tip (red).
  function armPoints(arm) {
    if (!arm) return { pts: [], size: [], color: [] };
    const pts = [], size = [], color = [];
    const near = (a, b) => Math.abs(a[0] - b[0]) + Math.abs(a[1] - b[1]) + Math.abs(a[2] - b[2]) < 1e-6;
    for (const p of arm.path) {
      const joint = arm.joints.some((j) => near(j, p));
      pts.push(p); size.push(joint ? 5 : 0.1); color.push("#0969da");
    }
    pts.push(arm.tip); size.push(7); color.push("#cf222e");
    return { pts: pts, size: size, color: color };
  }
  // A live frame's fast path: update the two live traces' WebGL objects in plotly's
  // gl3d scene and redraw it, instead of Plotly.restyle re-plotting every trace (70 ms
  // and more of JavaScript a frame where WebGL is software, which starves the page of
  // time for its messages). It reaches into plotly's internals (gd._fullData,
  // scene._scene.traces[uid].update, glplot.redraw), so it is guarded: a missing piece
  // or a changed number of points takes Plotly.restyle (state.slowDraws counts them).
  function fastArm(a, trail) {
    const gd = $("plot");
    const sc = gd._fullLayout && gd._fullLayout.scene && gd._fullLayout.scene._scene;
    if (!sc || !sc.traces || !sc.glplot || typeof sc.glplot.redraw !== "function" || !gd._fullData) return false;
    const parts = [[T.ARM, a.pts], [T.TRAIL, trail]];
    for (const [i, pts] of parts) {
      const fd = gd._fullData[i], obj = fd && sc.traces[fd.uid];
      if (!obj || typeof obj.update !== "function" || fd._length !== pts.length ||
          !gd.data[i].x || gd.data[i].x.length !== pts.length) return false;
    }
    for (const [i, pts] of parts) {
      const [x, y, z] = cols(pts), fd = gd._fullData[i];
      for (const o of [gd.data[i], fd]) { o.x = x; o.y = y; o.z = z; }
      sc.traces[fd.uid].update(fd);
    }
    sc.glplot.redraw();
    return true;
  }
  function setArm(arm, trail, live) {
    const a = armPoints(arm);
    if (live) {
      try { if (fastArm(a, trail)) return Promise.resolve(); } catch (e) { state.fastErrors.push(String(e)); }
      state.slowDraws += 1;
    }
    const [ax, ay, az] = cols(a.pts);
    const [tx, ty, tz] = cols(trail || []);
    return Plotly.restyle("plot", { x: [ax, tx], y: [ay, ty], z: [az, tz],
      "marker.size": [a.size, null], "marker.color": [a.color, null] }, [T.ARM, T.TRAIL]);
  }

  // ------------------------------------------------------------ panels
  function show(id, html) { const e = $(id); e.innerHTML = html; e.hidden = !html; }
  function stepsPanel(steps) {
    if (!steps || !steps.length) return "";
    const rows = steps.map((s) => {
      const f = s.feature;
      let what = s.note ? esc(s.note) : "";
      if (f && f.kind === "sphere") what = `sphere D ${(2 * f.radius_mm).toFixed(4)} mm (ball centres)`;
      else if (f && f.kind === "spheres") what = `${f.spheres.length} spheres`;
      else if (f && f.kind === "seat") what = `seat (${f.center_mm.map((v) => v.toFixed(3)).join(", ")})`;
      else if (f && f.kind === "plane") what = "plane";
      else if (f && f.kind === "lengths") what = `${f.positions.length} lengths` + (f.nominal_mm ? ` of ${f.nominal_mm} mm` : "");
      return `<tr data-step="${esc(s.id)}"><td>${esc(s.id)}</td><td>${esc(s.procedure)}</td><td class="num">${s.points}</td>` +
        `<td>${what}</td><td class="num">${um(s.rms_mm)}</td><td class="num">${um(s.max_mm)}</td></tr>`;
    }).join("");
    return `<h2>Steps and fitted features</h2><table id="steps-table"><tr><th>step</th><th>procedure</th><th class="num">points</th>` +
      `<th>feature</th><th class="num">rms um</th><th class="num">max um</th></tr>${rows}</table>`;
  }
  function verificationPanel(v) {
    if (!v) return "";
    const cls = (x) => (x === "PASS" ? "pass" : x === "FAIL" ? "fail" : "");
    const rows = v.results.map((r) => {
      const lim = r.limit_mm != null && r.mpe_mm != null && Math.abs(r.limit_mm - r.mpe_mm) > 5e-7
        ? ` (limit ${mm4(r.limit_mm)})` : "";
      return `<tr title="${esc(r.where)}"><td>${esc(r.name)}</td><td class="num">${mm4(r.value_mm)}</td>` +
        `<td class="num">${mm4(r.mpe_mm)}${lim}</td><td class="${cls(r.verdict)}">${esc(r.verdict)}</td></tr>`;
    }).join("");
    return `<h2>Verification <span class="verdict ${cls(v.verdict)}">${esc(v.verdict)}</span></h2>` +
      `<p class="small">decision rule ${esc(v.decision_rule)}; values and MPEs in mm (hover a row: where)</p>` +
      `<table id="verification-table"><tr><th>test</th><th class="num">value</th><th class="num">MPE</th>` +
      `<th>verdict</th></tr>${rows}</table>`;
  }
  // A before/after figure: lengths (names ending _mm) in um, anything else as it is.
  const fig = (name, v) => (typeof v !== "number" ? esc(v) : /_mm$/.test(name) ? (v * 1000).toFixed(1) + " um" : v.toPrecision(4));
  function calibrationPanel(c) {
    if (!c) { $("calibration").hidden = true; return; }
    $("calibration").hidden = false;
    const rows = c.steps.map((s) => `<tr><td>${esc(s.name)}</td><td>${esc(s.kinds.join(", "))}</td>` +
      `<td class="num">${s.after_mm.length}</td><td class="num">${um(s.rms_before_mm)}</td><td class="num">${um(s.rms_after_mm)}</td></tr>`).join("");
    let ba = "";
    if (c.before_after) {
      ba = "<h2>Before / after</h2><table><tr><th>figure</th><th class=num>before</th><th class=num>after</th><th class=num>factor</th></tr>" +
        c.before_after.map((r) => `<tr><td>${esc(r.figure)}</td><td class="num">${fig(r.figure, r.before)}</td><td class="num">${fig(r.figure, r.after)}</td>` +
          `<td class="num">${r.factor == null ? "" : Number(r.factor).toFixed(1) + "x"}</td></tr>`).join("") + "</table>";
    }
    $("caltable").innerHTML = `<table id="calibration-table"><tr><th>step</th><th>kind</th><th class="num">units</th>` +
      `<th class="num">rms before um</th><th class="num">rms after um</th></tr>${rows}</table>` +
      `<p class="small">${esc(c.chi_square)}</p>${ba}`;
    const data = [];
    c.steps.forEach((s, k) => {
      const jitter = (n) => Array.from({ length: n }, (_, i) => k + (n > 1 ? (i / (n - 1) - 0.5) * 0.6 : 0));
      data.push({ type: "scatter", mode: "markers", x: jitter(s.before_mm.length), y: s.before_mm.map((v) => v * 1000),
        marker: { size: 4, color: "#afb8c1" }, name: "before", showlegend: k === 0, legendgroup: "b", yaxis: "y2" });
      data.push({ type: "scatter", mode: "markers", x: jitter(s.after_mm.length), y: s.after_mm.map((v) => v * 1000),
        marker: { size: 4, color: "#0969da" }, name: "after", showlegend: k === 0, legendgroup: "a" });
    });
    Plotly.newPlot("calchart", data, {
      height: 300, margin: { l: 55, r: 10, t: 10, b: 60 }, legend: { orientation: "h", y: 1.08 },
      yaxis: { title: { text: "after, um" }, domain: [0, 0.58] },
      yaxis2: { title: { text: "before, um" }, domain: [0.68, 1] },
      xaxis: { tickvals: c.steps.map((_, k) => k), ticktext: c.steps.map((s) => s.name) },
    }, { displaylogo: false, responsive: true });
  }
  function notesPanel(notes) {
    show("notes", notes && notes.length ? "<h2>Notes</h2><ul>" + notes.map((n) => `<li>${esc(n)}</li>`).join("") + "</ul>" : "");
  }
  // The device's link temperatures of the newest frame, and the plan's stability band
  // (the feed judges it: aacmm.view.live.temperature_band); redrawn only on a change.
  let tempsShown = null;
  function tempsPanel(temps, band) {
    const key = JSON.stringify([temps, band]);
    if (key === tempsShown) return;
    tempsShown = key;
    if (!temps) { show("temps", ""); return; }
    const cells = temps.map((t, j) => `<tr><td>link ${j + 1}</td><td class="num">${t == null ? "no reading" : t.toFixed(2) + " °C"}</td></tr>`);
    let html = `<h2>Link temperatures</h2><table id="temps-table">${cells.join("")}</table>`;
    if (band) {
      const where = band.ref_c == null ? "" : ` about ${band.ref_c} °C`;
      if (band.range_c) html += `<div class="small" id="temps-range">this capture so far: ${band.range_c[0].toFixed(2)} .. ${band.range_c[1].toFixed(2)} °C</div>`;
      html += band.problem
        ? `<div class="advice" id="temps-band">outside the plan's ${band.band_c} °C band${where}: ${esc(band.problem)}</div>`
        : `<div class="advice ready" id="temps-band">within the plan's ${band.band_c} °C band${where}</div>`;
    }
    show("temps", html);
  }
  function capturePanel(c, advice) {
    if (!c) { show("capture", ""); return; }
    const pct = (100 * c.accepted) / Math.max(1, c.plan.points);
    let html = `<h2>Capture: ${esc(c.plan.title)}</h2>` +
      `<div>point <b id="cap-count">${c.accepted}</b> of ${c.plan.points} (${esc(c.status)})</div>` +
      `<div class="bar"><div style="width:${pct.toFixed(1)}%"></div></div>`;
    const n = c.next;
    if (n) {
      html += `<div>step ${n.step_number}/${c.plan.steps} <b>${esc(n.step)}</b>: ${esc(n.procedure)}` +
        (n.artefact ? ` on ${esc(n.artefact)}` + (n.artefact_type ? ` (${esc(n.artefact_type)})` : "") : "") +
        `, point ${n.point_in_step} of ${n.points_in_step}</div>` +
        `<div class="prompt" id="cap-prompt">[${n.number}/${c.plan.points}] ${esc(n.text)}</div>`;
      if (n.note) html += `<div class="small">${esc(n.note)}</div>`;
      if (n.new_articulation) {
        if (!c.articulations.length) html += `<div class="advice ready">a new articulation: the first of this step</div>`;
        else if (advice) {
          html += advice.ready
            ? `<div class="advice ready" id="cap-advice">new articulation: this pose differs from all ${c.articulations.length} taken</div>`
            : `<div class="advice" id="cap-advice">next articulation: turn joint${advice.turn.length > 1 ? "s" : ""} ` +
              `<b>${advice.turn.join(", ")}</b> (within 20 deg of articulation ${advice.nearest})</div>`;
        }
      }
    } else {
      html += `<div class="prompt" id="cap-prompt">plan complete${c.status === "running" ? ": confirm at the arm (button 0) or undo (button 1)" : ""}</div>`;
    }
    if (c.event) html += `<div class="event ${esc(c.event.kind)}" id="cap-event">${esc(c.event.text)}</div>`;
    html += `<div class="small">undo the last point: button 1 on the arm (or <kbd>u</kbd> at the capture terminal)</div>`;
    show("capture", html);
  }

  // ------------------------------------------------------------ live
  let pendingFrame = null, pendingCapture = null, drawing = false;
  function onFrame(f) {
    const now = Date.now();
    state.frames += 1;
    f.recv_ms = now;
    if (f.valid && state.trailMax > 0) { state.trail.push(f.tip); if (state.trail.length > state.trailMax) state.trail.shift(); }
    state.history.push({ seq: f.seq, t_us: f.device_time_us, tip: f.tip, valid: f.valid, host_ms: f.host_ms, recv_ms: now });
    if (state.history.length > HISTORY) state.history.shift();
    pendingFrame = f;
    schedule();
  }
  function onCapture(c) {
    const now = Date.now();
    state.captureLog.push([now, c.accepted, c.updated_ms]);  // arrival, points, made
    if (state.captureLog.length > HISTORY) state.captureLog.shift();
    for (const p of c.points) if (p.slot != null && !(p.slot in state.pointSeen)) state.pointSeen[p.slot] = now;
    const have = new Set(c.points.map((p) => p.slot));
    for (const k of Object.keys(state.pointSeen)) if (!have.has(Number(k))) delete state.pointSeen[k];
    if (c.event && (!state.capture || c.updated_ms !== state.capture.updated_ms)) {
      state.events.push({ kind: c.event.kind, slot: c.event.slot, text: c.event.text, at: now });
    }
    state.capture = c;
    pendingCapture = c;
    schedule();
  }
  // The trail at its full length from the start (leading gaps): its number of points
  // stays the same, so the fast path applies from the first frames on.
  function paddedTrail() {
    const t = state.trail;
    return t.length >= state.trailMax ? t : new Array(state.trailMax - t.length).fill(null).concat(t);
  }
  function schedule() { if (!drawing) { drawing = true; requestAnimationFrame(draw); } }
  async function draw() {
    const started = performance.now();
    try {
      const c = pendingCapture; pendingCapture = null;
      if (c) { await setPoints(c.points, c.steps); capturePanel(c, state.lastFrame && state.lastFrame.advice); show("steps", stepsPanel(c.steps)); }
      const f = pendingFrame; pendingFrame = null;
      if (f) {
        f.arm.tip = f.tip;
        const t0 = performance.now();
        await setArm(f.arm, paddedTrail(), true);
        state.drawJs.push(performance.now() - t0);
        if (state.drawJs.length > HISTORY) state.drawJs.shift();
        const done = Date.now();
        f.render_ms = done;
        state.renders += 1;
        if (state.liveAt == null && state.connected) state.liveAt = done;
        state.lastFrame = f;
        state.latencies.push(done - f.host_ms);
        if (state.latencies.length > HISTORY) state.latencies.shift();
        if (state.capture && state.capture.next && state.capture.next.new_articulation && f.advice) capturePanel(state.capture, f.advice);
        tempsPanel(f.temps_c, f.temp_band);
        status();
      }
    } catch (e) {
      state.errors.push(String(e));
    } finally {
      // Rest as long as the draw took: the page's thread stays free half the time for
      // the messages (and the person), however slow drawing is on this machine.
      const rest = Math.min(500, performance.now() - started);
      setTimeout(() => {
        drawing = false;
        if (pendingFrame || pendingCapture) schedule();
      }, rest);
    }
  }
  let rateMark = { t: Date.now(), n: 0, fps: 0 };
  function status() {
    const now = Date.now();
    if (now - rateMark.t >= 1000) { rateMark = { t: now, n: state.renders, fps: ((state.renders - rateMark.n) * 1000) / (now - rateMark.t) }; }
    const f = state.lastFrame;
    const e = $("status");
    e.className = "status " + (state.connected ? "live" : "down");
    e.textContent = state.stopped
      ? "aacmm view has stopped (the capture or the command ended): what is shown stays; reload when it runs again"
      : state.connected
      ? `live · ${rateMark.fps.toFixed(0)} frames/s` + (f ? ` · tip ${f.tip.map((v) => v.toFixed(2)).join(", ")} mm` + (f.valid ? "" : " · NO POINT (encoder fault)") : "")
      : "disconnected from aacmm view: reconnecting";
  }
  function connect() {
    const ws = new WebSocket(`ws://${location.host}/ws`);
    ws.onopen = () => { state.connected = true; status(); };
    // A batch of messages (the newest of each kind); "ack" asks for the next one.
    ws.onmessage = (ev) => {
      let batch;
      try { batch = JSON.parse(ev.data); } catch (e) { state.errors.push("bad message"); return; }
      for (const m of batch) {
        if (m.type === "frame") onFrame(m);
        else if (m.type === "capture") onCapture(m);
      }
      ws.send("ack");
    };
    // 1001 "going away": the server stopped on purpose (the capture ended, Ctrl-C), so
    // there is nothing to reconnect to; anything else (a dropped link) retries.
    ws.onclose = (ev) => {
      state.connected = false;
      if (ev.code === 1001) state.stopped = true; else setTimeout(connect, 1000);
      status();
    };
    ws.onerror = () => {};
  }

  // ------------------------------------------------------------ start
  async function start(scene) {
    state.scene = scene;
    state.mode = scene.kind === "live" ? "live" : "offline";
    $("title").textContent = scene.title || "aacmm view";
    $("subtitle").textContent = scene.subtitle || "";
    document.title = scene.title || "aacmm view";
    // One device pixel per CSS pixel: plotly's default (2) quadruples the WebGL work.
    await Plotly.newPlot("plot", traces(), layout(scene.kind === "live" ? scene.reach_mm : null),
      { displaylogo: false, responsive: true, plotGlPixelRatio: 1 });
    if (state.mode === "live") {
      state.trailMax = scene.trail_max || 0;
      state.trail = (scene.trail || []).slice(-state.trailMax);
      if (scene.capture) onCapture(scene.capture);
      if (scene.frame) onFrame(scene.frame);
      status();
      connect();
    } else {
      $("status").textContent = scene.kind;
      await setPoints(scene.points, scene.steps);
      await setArm(scene.arm, scene.trail);
      show("steps", stepsPanel(scene.steps));
      show("verification", verificationPanel(scene.verification));
      calibrationPanel(scene.calibration);
      notesPanel(scene.notes);
    }
    state.readyAt = Date.now();
    state.ready = true;
  }
  const embedded = document.getElementById("aacmm-scene");
  const go = embedded ? Promise.resolve(JSON.parse(embedded.textContent))
    : fetch("scene.json", { cache: "no-store" }).then((r) => r.json());
  go.then(start).catch((e) => { state.errors.push(String(e)); $("status").textContent = "error: " + e; });
})();
