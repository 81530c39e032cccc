"""The inline 3D view: meshcat's own three.js viewer inside an anywidget, fed over the kernel's comm channel.

The browser needs nothing but the Jupyter connection it already has (JupyterLab 4, Notebook 7, VS Code, a JupyterHub
under any base_url, Binder): no second port, no proxy, no iframe. meshcat-python ships its viewer as one webpack
bundle (meshcat/viewer/dist/main.min.js, a UMD module named MeshCat, with three.js inside); the widget's ES module
loads it as a CommonJS module and gives each view a `MeshCat.Viewer`. A view that opens asks the kernel for the scene
("ready") and is sent the whole SceneRecord once; every later drawing call of the Viewer reaches it as one message of
msgpack blobs, which meshcat decodes itself (`handle_command_bytearray`). What a view cannot do (no WebGL, no answer
from the kernel) it says in the notebook, with the reason.
"""

from __future__ import annotations

import functools
from importlib.resources import files

import anywidget
import traitlets

from armlab.viz.scene import MirroredWindow

__all__ = ["SceneView", "NO_SCENE_AFTER_S", "CLOSED_NOTE"]

NO_SCENE_AFTER_S = 20          # a view that has no scene by then says that the kernel did not answer
CLOSED_NOTE = ("the 3D viewer is closed (viewer.close() stopped it): run the notebook's viewer cells again for a "
               "live one")

_VIEW_JS = r"""
const MeshCat = module.exports;

function note(box, text) {
  box.textContent = text;
  box.style.display = text ? "block" : "none";
}

function render({ model, el }) {
  const id = Math.random().toString(36).slice(2);
  const pane = document.createElement("div");
  pane.className = "armlab-viewer";
  pane.dataset.frames = "0";
  pane.dataset.messages = "0";
  pane.style.cssText = "position:relative;width:100%;border:1px solid #ccc;box-sizing:border-box;overflow:hidden";
  pane.style.height = model.get("height_px") + "px";
  const status = document.createElement("div");
  status.className = "armlab-viewer-status";
  status.style.cssText = "position:absolute;left:0;right:0;top:0;padding:0.5em;background:#eee;color:#333;" +
                         "font:13px sans-serif;z-index:10;white-space:normal";
  pane.appendChild(status);
  el.appendChild(pane);
  note(status, "connecting to the kernel for the 3D scene ...");

  let viewer;
  try {
    viewer = new MeshCat.Viewer(pane);
  } catch (e) {
    const why = "the 3D view cannot start: WebGL is not available in this browser (" + e + ")";
    note(status, why);
    model.send({ type: "error", view: id, text: why });
    return () => {};
  }
  pane.dataset.state = "connecting";
  const fit = viewer.set_3d_pane_size.bind(viewer);     // meshcat sizes to the window's height: use the pane's
  viewer.set_3d_pane_size = (w, h) => fit(w ?? (pane.clientWidth || 600), h ?? (pane.clientHeight || 300));
  let dirty = false, alive = true, got_scene = false;
  const draw = viewer.render.bind(viewer);
  viewer.render = () => {     // counts the pictures that show a new message: the view's frame rate
    draw();
    if (dirty) { dirty = false; pane.dataset.frames = String(+pane.dataset.frames + 1); }
  };
  const apply = (buffers) => {
    for (const b of buffers) {
      viewer.handle_command_bytearray(new Uint8Array(b.buffer, b.byteOffset, b.byteLength));
    }
    pane.dataset.messages = String(+pane.dataset.messages + 1);
    dirty = true;
  };
  const on_message = (msg, buffers) => {
    if (msg.type === "scene" && msg.to === id) {
      apply(buffers); got_scene = true; pane.dataset.state = "live";
      note(status, model.get("notice"));
    } else if (msg.type === "update" && got_scene) {
      apply(buffers);
    }
  };
  model.on("msg:custom", on_message);
  const on_notice = () => note(status, model.get("notice"));
  model.on("change:notice", on_notice);
  const on_height = () => { pane.style.height = model.get("height_px") + "px"; viewer.set_3d_pane_size(); };
  model.on("change:height_px", on_height);
  const resize = new ResizeObserver(() => viewer.set_3d_pane_size());
  resize.observe(pane);
  const timer = setTimeout(() => {
    if (!got_scene && alive) {
      pane.dataset.state = "no-answer";
      note(status, "no 3D scene from the kernel after " + model.get("timeout_s") + " s: the kernel is busy, " +
                   "stopped or restarted; run the viewer's cell again");
    }
  }, 1000 * model.get("timeout_s"));
  model.send({ type: "ready", view: id });
  return () => {
    alive = false;
    clearTimeout(timer);
    resize.disconnect();
    model.off("msg:custom", on_message);
    model.off("change:notice", on_notice);
    model.off("change:height_px", on_height);
    viewer.animate = () => {};          // ends meshcat's requestAnimationFrame loop
    viewer.renderer.dispose();
  };
}

export default { render };
"""


@functools.cache
def _esm() -> str:
    """meshcat's bundle run as a CommonJS module (its UMD header picks module.exports), then the view code."""
    bundle = (files("meshcat") / "viewer" / "dist" / "main.min.js").read_text(encoding="utf-8")
    return f"const module = {{ exports: {{}} }};\nconst exports = module.exports;\n{bundle}\n{_VIEW_JS}"


class SceneView(anywidget.AnyWidget):
    """A live inline view of one Viewer's scene (see the module docstring). Made by `Viewer.widget()`.

    Attributes: `height_px` (the view's height, px), `notice` (a line shown over the view, e.g. that the viewer is
    closed), `errors` (what views reported they could not do, e.g. no WebGL).
    """

    height_px = traitlets.Int(420).tag(sync=True)
    notice = traitlets.Unicode("").tag(sync=True)
    timeout_s = traitlets.Int(NO_SCENE_AFTER_S).tag(sync=True)

    def __init__(self, window: MirroredWindow, height_px: int = 420):
        if not 100 <= int(height_px) <= 4000:
            raise ValueError(f"height_px must lie in [100, 4000] px, got {height_px}")
        import ipywidgets

        super().__init__(_esm=_esm(), height_px=int(height_px), layout=ipywidgets.Layout(width="100%"))
        self._window = window
        self.errors: list[str] = []
        self.on_msg(self._on_view_message)
        window.add_view(self._push)

    def _push(self, blobs: list[bytes]) -> None:
        if self.comm is not None:
            self.send({"type": "update"}, buffers=blobs)

    def _on_view_message(self, _widget, content, _buffers) -> None:
        kind = content.get("type") if isinstance(content, dict) else None
        if kind == "ready":
            self.send({"type": "scene", "to": str(content.get("view", ""))}, buffers=self._window.record.replay())
        elif kind == "error":
            self.errors.append(str(content.get("text", ""))[:500])

    def detach(self, notice: str = CLOSED_NOTE) -> None:
        """Stop following the scene and show `notice` over the last picture."""
        self._window.remove_view(self._push)
        self.notice = notice

    def __repr__(self) -> str:     # short and deterministic: nbval compares a displayed widget's text
        return "ViewerPane(live 3D view of the station; run the cell to see it)"
