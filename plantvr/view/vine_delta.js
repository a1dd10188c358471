// ViNE review page hook (issue 14): brush strokes picked on the server, per-vertex colour deltas applied to the
// vtk.js actors drawn by a trame-vtk VtkLocalView in place, one render per animation frame, and a coarse level
// of detail drawn while a stroke or an orbit drag runs.
//
// Deltas. The server sends batches {seq, n, ids, rgba, more}: `ids` are changed proxy vertex ids (little-endian
// uint32) and `rgba` their colours (uint8, 4 per id), as binary (Uint8Array through wslink's msgpack) or base64
// strings; `n` picks the actor whose point array "rgba" has n 4-component tuples; `more` holds further
// {n, ids, rgba} parts (the other level of detail) of the same batch. Batches come in the state variable
// `vine_delta` (clicks, undo, redo) or as the return value of a stroke request. A gap in `seq` (two state
// deltas coalesced by Vue's watcher before this ran) asks the server for a full resync (trigger
// "vine_resync"), so no stroke is ever lost.
//
// Strokes. A left press on the view paints instead of orbiting when the state's `paint_drag` is on or ctrl is
// held: the press, the moves and the release go to the server (trigger "vine_stroke" with the positions in CSS
// px from the canvas's top-left corner, the canvas size and the vtk.js camera); at most one request is in
// flight, the positions that arrive meanwhile travel together in the next one. Without paint_drag a click (press
// and release within 4 px) paints one stamp the same way; longer drags orbit (vtk.js).
//
// A page that loads while the server's scene is older than the deltas sent since (state `vine_stale`) asks for
// a resync once its view is ready.
//
// Level of detail. When the state's `n_lod` is set, the actor with n_lod colour tuples (hidden at rest) is
// drawn instead of the display proxy's (n_proxy tuples) from the stroke's press (or an orbit's start) until the
// stroke's last batch has been applied (or the orbit ends).
//
// Timings. `window.vineDelta.log` records every stroke request (performance.now() at send and at reply, the
// positions it carried, the bytes of colours it brought back) and `renders` the time of each render call;
// the benchmark reads them.
(function () {
  function toBytes(x) {
    if (x == null) return new Uint8Array(0);
    if (x instanceof Uint8Array) return x;
    if (x instanceof ArrayBuffer) return new Uint8Array(x);
    if (ArrayBuffer.isView(x)) return new Uint8Array(x.buffer, x.byteOffset, x.byteLength);
    if (typeof x === "string") {
      const s = atob(x);
      const u = new Uint8Array(s.length);
      for (let i = 0; i < s.length; i++) u[i] = s.charCodeAt(i);
      return u;
    }
    return new Uint8Array(0);
  }

  // The vtk.js view object of a VtkLocalView component: it is what the component provides as "view".
  function localView(ref) {
    const comp = window.trame && window.trame.refs && window.trame.refs[ref];
    if (!comp) return null;
    const inst = comp.$ || comp;
    return (inst.provides && inst.provides.view) || null;
  }

  function stateGet(name) {
    const st = window.trame && window.trame.state;
    return st && st.get ? st.get(name) : undefined;
  }

  // The actors whose point array "rgba" has n 4-component tuples, with that array.
  function actorsWith(view, n) {
    const out = [];
    if (!view || !view.renderer || !n) return out;
    for (const actor of view.renderer.getActors()) {
      const mapper = actor.getMapper && actor.getMapper();
      const data = mapper && mapper.getInputData && mapper.getInputData();
      if (!data || !data.getPointData) continue;
      const pd = data.getPointData();
      const sc = pd.getArrayByName("rgba") || pd.getScalars();
      if (sc && sc.getNumberOfComponents() === 4 && sc.getNumberOfTuples() === n) out.push({ actor, data, sc });
    }
    return out;
  }

  // Arrays this hook owns. trame-vtk's synchroniser caches fetched arrays by content hash and hands the same
  // typed array to the actor, so the first delta after a sync copies it once (the cache keeps the content its
  // hash names); later deltas then write into the copy in place.
  const owned = new WeakSet();
  const guarded = new WeakSet();
  const REF = "vine_view";

  // Colour buffer of an actor's triangles as vtk.js uploaded it: one RGBA per triangle corner, corner j of the
  // polys' connectivity (vtk.js draws triangles unindexed). Writing the changed vertices' corners into it
  // (bufferSubData of the touched 64 KiB blocks, from a shadow copy) recolours the actor without the full
  // rebuild of points, normals and colours that marking its data modified costs (seconds at 1.5 M triangles).
  // Used only while the buffer is current (built after the last modification of the actor's data); any other
  // case takes the ordinary path.
  const caches = new WeakMap();

  // Show or hide an actor without marking it modified: vtk.js rebuilds a modified actor's vertex buffers.
  function setVisible(actor, on) {
    const m = actor.get && actor.get();
    if (m && "visibility" in m) m.visibility = !!on;
    else actor.setVisibility(on);
  }
  function colourBuffer(view, actor, data, sc) {
    try {
      const glrw = view.openglRenderWindow;
      const node = glrw && glrw.getViewNodeFor(actor.getMapper());
      const m = node && node.get && node.get();
      if (!m || !m.primitives || !m.primTypes || !m.VBOBuildTime) return null;
      const built = m.VBOBuildTime.getMTime();
      if (built < data.getMTime() || built < actor.getMapper().getMTime()) return null;
      const cabo = m.primitives[m.primTypes.Tris].getCABO();
      const bo = cabo.getColorBO && cabo.getColorBO();
      if (!bo || !bo.getHandle || !bo.getHandle()) return null;
      for (let k = m.primTypes.Start; k < m.primTypes.End; k++) {
        if (k !== m.primTypes.Tris && m.primitives[k].getCABO().getElementCount()) return null;
      }
      const polys = data.getPolys().getData();
      let c = caches.get(actor);
      if (!c || c.polys !== polys || c.built !== built || c.bo !== bo) {
        const nf = polys.length / 4;
        if (nf * 3 !== cabo.getElementCount()) return null;
        const nv = sc.getNumberOfTuples();
        const conn = new Uint32Array(3 * nf);
        for (let f = 0; f < nf; f++) {
          if (polys[4 * f] !== 3) return null;                // triangles only
          conn[3 * f] = polys[4 * f + 1]; conn[3 * f + 1] = polys[4 * f + 2]; conn[3 * f + 2] = polys[4 * f + 3];
        }
        const start = new Uint32Array(nv + 1);                // corners of each vertex (CSR)
        for (let j = 0; j < conn.length; j++) start[conn[j] + 1] += 1;
        for (let v = 0; v < nv; v++) start[v + 1] += start[v];
        const fill = start.slice(0, nv), corners = new Uint32Array(conn.length);
        for (let j = 0; j < conn.length; j++) corners[fill[conn[j]]++] = j;
        const a = sc.getData(), shadow = new Uint8Array(4 * conn.length);
        for (let j = 0; j < conn.length; j++) {
          const s = 4 * conn[j], d = 4 * j;
          shadow[d] = a[s]; shadow[d + 1] = a[s + 1]; shadow[d + 2] = a[s + 2]; shadow[d + 3] = a[s + 3];
        }
        c = { polys, built, bo, start, corners, shadow, dirty: new Uint8Array(Math.ceil(shadow.length / 65536) + 1) };
        caches.set(actor, c);
      }
      return {
        write(ids, rgba) {
          const gl = glrw.getContext();
          if (!gl) return false;
          const { start, corners, shadow, dirty } = c;
          dirty.fill(0);
          for (let i = 0; i < ids.length; i++) {
            const s = 4 * i;
            for (let q = start[ids[i]]; q < start[ids[i] + 1]; q++) {
              const d = 4 * corners[q];
              shadow[d] = rgba[s]; shadow[d + 1] = rgba[s + 1]; shadow[d + 2] = rgba[s + 2]; shadow[d + 3] = rgba[s + 3];
              dirty[d >> 16] = 1;
            }
          }
          gl.bindBuffer(gl.ARRAY_BUFFER, c.bo.getHandle());
          for (let b = 0; b < dirty.length; b++) {
            if (!dirty[b]) continue;
            let e = b;
            while (e + 1 < dirty.length && dirty[e + 1]) e++;
            const lo = b << 16, hi = Math.min((e + 1) << 16, shadow.length);
            gl.bufferSubData(gl.ARRAY_BUFFER, lo, shadow.subarray(lo, hi));
            b = e;
          }
          gl.bindBuffer(gl.ARRAY_BUFFER, null);
          return true;
        },
      };
    } catch (err) {
      return null;
    }
  }

  const vine = {
    seq: 0,
    applied: 0,      // delta batches applied in place
    fast: 0,         // actor recolourings written straight into the GPU colour buffer
    vertices: 0,     // proxy vertices recoloured in place, in total
    copies: 0,       // copy-on-first-write of a synchronised colour array
    resyncs: 0,      // full re-synchronisations asked for (missed delta, page loaded late, view not ready)
    renders: [],     // [performance.now() after, ms spent] of each render this hook asked for
    log: [],         // stroke requests: {phase, points, sent, back, bytes}
    strokes: 0,      // strokes finished
    lodShown: false,
    stroke: null,
    finish: false,   // wait for each render to be drawn (benchmarks)
    resync(seq) {
      vine.resyncs += 1;
      window.trame.trigger("vine_resync", [seq]);
      return false;
    },
    // one render at the next animation frame, however many batches arrive before it
    scheduleRender(view) {
      if (vine._raf) return;
      vine._raf = requestAnimationFrame(() => {
        vine._raf = 0;
        const t = performance.now();
        view.renderWindow.render();
        if (vine.finish) {               // benchmarks: wait until the (software) GPU has drawn the frame: reading
          const gl = view.openglRenderWindow && view.openglRenderWindow.getContext();   // a pixel back forces
          if (gl) gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4)); // it (gl.finish does not)
        }
        const t1 = performance.now();
        vine.renders.push([t1, t1 - t]);
        if (vine.renders.length > 5000) vine.renders.splice(0, 1000);
      });
    },
    applyPart(view, part) {
      const targets = actorsWith(view, part.n);
      if (!targets.length) return -1;
      const idb = toBytes(part.ids);
      const ids = new Uint32Array(idb.buffer.slice(idb.byteOffset, idb.byteOffset + idb.byteLength));
      const rgba = toBytes(part.rgba);
      for (const { actor, data, sc } of targets) {
        let a = sc.getData();
        const fast = colourBuffer(view, actor, data, sc);     // before the copy below (same content)
        if (!owned.has(a)) {
          a = a.slice();
          sc.setData(a, 4);
          owned.add(a);
          vine.copies += 1;
        }
        for (let i = 0; i < ids.length; i++) {
          const d = 4 * ids[i], s = 4 * i;
          a[d] = rgba[s]; a[d + 1] = rgba[s + 1]; a[d + 2] = rgba[s + 2]; a[d + 3] = rgba[s + 3];
        }
        if (fast && fast.write(ids, rgba)) {
          vine.fast += 1;         // only the changed corners' colours went to the GPU; no buffer rebuild
        } else {
          sc.modified();
          data.modified();        // vtk.js rebuilds the actor's vertex buffers at the next render
        }
      }
      return ids.length;
    },
    apply(ref, delta) {
      if (!delta || typeof delta.seq !== "number") return false;
      const gap = delta.seq !== vine.seq + 1;
      vine.seq = delta.seq;
      const view = localView(ref || REF);
      if (gap || !view || !view.renderer) return vine.resync(delta.seq);
      let n = 0;
      for (const part of [delta, ...(delta.more || [])]) {
        const k = vine.applyPart(view, part);
        if (k < 0) return vine.resync(delta.seq);      // scene still loading: take the server's colours
        n += k;
      }
      vine.applied += 1;
      vine.vertices += n;
      vine.scheduleRender(view);
      return true;
    },
    // the scene has arrived: the display proxy's actor (and the level of detail's) with their colour arrays
    ready() {
      const view = localView(REF), np = stateGet("n_proxy"), nl = stateGet("n_lod");
      return !!(view && view.renderer && actorsWith(view, np).length && (!nl || actorsWith(view, nl).length));
    },
    // draw the coarse level of detail (on) or the display proxy (off)
    showLod(view, on) {
      const nl = stateGet("n_lod"), np = stateGet("n_proxy");
      if (!view || !nl) return;
      vine.guardLod(view);
      const coarse = actorsWith(view, nl), fine = actorsWith(view, np);
      if (!coarse.length || !fine.length) return;
      vine.lodShown = on;
      for (const { actor } of coarse) setVisible(actor, on);
      for (const { actor } of fine) setVisible(actor, !on);
      vine.scheduleRender(view);
    },
    // The server keeps the level of detail's actor visible (trame-vtk sends hidden actors without their
    // data); at rest this page hides it, also right after a scene synchronisation sets it visible again.
    guardLod(view) {
      const nl = stateGet("n_lod");
      if (!view || !view.renderer || !nl) return;
      for (const { actor } of actorsWith(view, nl)) {
        if (!guarded.has(actor)) {
          guarded.add(actor);
          actor.onModified(() => { if (!vine.lodShown && actor.getVisibility()) setVisible(actor, false); });
        }
        if (!vine.lodShown && actor.getVisibility()) {
          setVisible(actor, false);
          vine.scheduleRender(view);
        }
      }
    },
  };

  // ---------------------------------------------------------------- strokes (server-side picking)
  function canvasPos(e, el) {
    const c = el.querySelector("canvas") || el;
    const r = c.getBoundingClientRect();
    return { p: [e.clientX - r.left, e.clientY - r.top], size: [r.width, r.height] };
  }

  function cameraOf(view) {
    const c = view.renderer.getActiveCamera();
    return {
      position: Array.from(c.getPosition()), focalPoint: Array.from(c.getFocalPoint()),
      viewUp: Array.from(c.getViewUp()), viewAngle: c.getViewAngle(),
      parallelProjection: !!c.getParallelProjection(), parallelScale: c.getParallelScale(),
    };
  }

  function batchBytes(d) {
    if (!d) return 0;
    let b = 0;
    for (const p of [d, ...(d.more || [])]) b += toBytes(p.ids).byteLength + toBytes(p.rgba).byteLength;
    return b;
  }

  async function send(phase, points, size, view) {
    const entry = { phase, points: points.length, sent: performance.now(), back: 0, bytes: 0 };
    vine.log.push(entry);
    if (vine.log.length > 5000) vine.log.splice(0, 1000);
    let res = null;
    try {
      res = await window.trame.trigger("vine_stroke", [phase, points, cameraOf(view), size]);
    } catch (err) {
      entry.error = String(err);
    }
    entry.back = performance.now();
    entry.bytes = batchBytes(res);
    if (res) vine.apply(REF, res);
    return res;
  }

  async function pump() {
    const s = vine.stroke;
    if (!s || s.busy) return;
    const phase = !s.begun ? "begin" : s.ended ? "end" : "move";
    if (phase === "move" && !s.pts.length) return;
    s.busy = true;
    const pts = s.pts;
    s.pts = [];
    await send(phase, pts, s.size, s.view);
    s.busy = false;
    if (phase === "begin") s.begun = true;
    if (phase === "end") {
      vine.stroke = null;
      vine.strokes += 1;
      vine.showLod(s.view, false);
      return;
    }
    pump();
  }

  function inView(e) {
    const el = e.target && e.target.closest ? e.target.closest(".vine-view") : null;
    return el;
  }

  window.addEventListener("pointerdown", (e) => {
    const el = inView(e);
    if (!el || e.button !== 0) return;
    const view = localView(REF);
    if (!view || !view.renderer) return;
    const { p, size } = canvasPos(e, el);
    vine.down = { x: e.clientX, y: e.clientY, p, size, el };
    const paint = (stateGet("paint_drag") || e.ctrlKey) && !e.shiftKey && !e.altKey;
    if (!paint) return;
    e.stopPropagation();
    e.preventDefault();
    vine.down = null;
    if (vine.stroke) return;
    vine.stroke = { view, el, size, pts: [p], begun: false, ended: false, busy: false };
    vine.showLod(view, true);
    pump();
  }, true);

  window.addEventListener("pointermove", (e) => {
    const s = vine.stroke;
    if (!s || s.ended) return;
    e.stopPropagation();
    e.preventDefault();
    s.pts.push(canvasPos(e, s.el).p);
    pump();
  }, true);

  window.addEventListener("pointerup", (e) => {
    const s = vine.stroke;
    if (s && !s.ended) {
      e.stopPropagation();
      e.preventDefault();
      s.pts.push(canvasPos(e, s.el).p);
      s.ended = true;
      pump();
      return;
    }
    const d = vine.down;
    vine.down = null;
    if (!d || e.button !== 0) return;
    if (Math.abs(e.clientX - d.x) + Math.abs(e.clientY - d.y) > 4) return;      // an orbit drag
    const view = localView(REF);
    if (view && view.renderer) send("click", [d.p], d.size, view);
  }, true);

  // orbit drags draw the level of detail too
  function hookInteractor() {
    const view = localView(REF);
    if (!view || !view.interactor) return setTimeout(hookInteractor, 500);
    if (view.__vineHooked) return;
    view.__vineHooked = true;
    // a page opened after deltas were sent got the scene of the last synchronisation: take the current one
    if (stateGet("vine_stale") && !vine.applied && !vine.resyncs) vine.resync(0);
    const it = view.interactor;
    if (it.onStartAnimation) it.onStartAnimation(() => { if (!vine.stroke) vine.showLod(view, true); });
    if (it.onEndAnimation) it.onEndAnimation(() => { if (!vine.stroke) vine.showLod(view, false); });
    return null;
  }
  setTimeout(hookInteractor, 500);
  setInterval(() => vine.guardLod(localView(REF)), 250);

  window.vineDelta = vine;
  if (window.trame && window.trame.utils) window.trame.utils.vine = vine;
})();
