// ViNE review page hook (issue 14): apply per-vertex colour deltas to the vtk.js actor drawn by a trame-vtk
// VtkLocalView, in place, instead of re-sending the whole colour array.
//
// The server sets the state variable `vine_delta` = {seq, n, ids, rgba}: `ids` are the changed proxy vertex ids
// (little-endian uint32) and `rgba` their colours (uint8, 4 per id), either as binary (Uint8Array through
// wslink's msgpack) or base64 strings. `n` is the proxy vertex count: only a point array named "rgba" with that
// many 4-component tuples is touched. A gap in `seq` (two deltas coalesced by Vue's watcher before this ran)
// asks the server for a full colour resync (trigger "vine_resync"), so no stroke is ever lost.
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

  // Arrays this hook owns. trame-vtk's synchroniser caches fetched arrays by content hash and hands the same
  // typed array to the actor, so the first delta after a sync copies it once (the cache keeps the content its
  // hash names); later deltas then write into the copy in place.
  const owned = new WeakSet();

  const vine = {
    seq: 0,
    applied: 0,      // deltas applied in place
    vertices: 0,     // proxy vertices recoloured in place, in total
    copies: 0,       // copy-on-first-write of a synchronised colour array
    resyncs: 0,      // full re-synchronisations asked for (missed delta, page loaded late, view not ready)
    resync(seq) {
      vine.resyncs += 1;
      window.trame.trigger("vine_resync", [seq]);
      return false;
    },
    apply(ref, delta) {
      if (!delta || typeof delta.seq !== "number") return false;
      const gap = delta.seq !== vine.seq + 1;
      vine.seq = delta.seq;
      const view = localView(ref);
      if (gap || !view || !view.renderer) return vine.resync(delta.seq);
      const idb = toBytes(delta.ids);
      const ids = new Uint32Array(idb.buffer.slice(idb.byteOffset, idb.byteOffset + idb.byteLength));
      const rgba = toBytes(delta.rgba);
      let done = false;
      for (const actor of view.renderer.getActors()) {
        const mapper = actor.getMapper && actor.getMapper();
        const data = mapper && mapper.getInputData && mapper.getInputData();
        if (!data || !data.getPointData) continue;
        const pd = data.getPointData();
        const sc = pd.getArrayByName("rgba") || pd.getScalars();
        if (!sc || sc.getNumberOfComponents() !== 4 || sc.getNumberOfTuples() !== delta.n) continue;
        let a = sc.getData();
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
        sc.modified();
        data.modified();
        done = true;
      }
      if (!done) return vine.resync(delta.seq);      // scene still loading: take the server's colours
      vine.applied += 1;
      vine.vertices += ids.length;
      view.renderWindow.render();
      return true;
    },
  };
  window.vineDelta = vine;
  if (window.trame && window.trame.utils) window.trame.utils.vine = vine;
})();
