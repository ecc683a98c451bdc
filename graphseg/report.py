"""Self-contained HTML report: metrics, per-view overlays, an interactive 3D cloud.

The page embeds everything (images as base64 PNG, points as JSON, a small
canvas viewer in plain JavaScript): it works offline, with no CDN and no
plotting library. Drag to rotate, scroll to zoom.
"""

from __future__ import annotations

import base64
import html
import json
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["palette", "overlay", "render_report"]


def palette(n: int) -> np.ndarray:
    """``n + 1`` distinct uint8 RGB colours; row 0 (background) is black.

    Examples
    --------
    >>> palette(2).shape
    (3, 3)
    """
    import colorsys

    cols = [(0, 0, 0)]
    for k in range(n):
        h = (k * 0.618033988749895) % 1.0
        r, g, b = colorsys.hsv_to_rgb(h, 0.75, 0.95)
        cols.append((int(r * 255), int(g * 255), int(b * 255)))
    return np.array(cols, np.uint8)


def overlay(rgb: np.ndarray, labels: np.ndarray, colors: np.ndarray, *, alpha: float = 0.55, ids: bool = True) -> np.ndarray:
    """RGB with each object tinted in its colour, outlined, and its id written at its centre."""
    import cv2

    out = np.asarray(rgb, np.float32).copy()
    lab = np.asarray(labels)
    fg = lab > 0
    out[fg] = (1 - alpha) * out[fg] + alpha * colors[lab[fg]].astype(np.float32)
    out = out.astype(np.uint8)
    edges = cv2.morphologyEx(lab.astype(np.uint16), cv2.MORPH_GRADIENT, np.ones((3, 3), np.uint8)) > 0
    out[edges & fg] = 255
    if ids:
        scale = max(0.4, lab.shape[0] / 900)
        for k in np.unique(lab[fg]):
            ys, xs = np.nonzero(lab == k)
            x, y = int(np.median(xs)), int(np.median(ys))
            cv2.putText(out, str(int(k)), (x, y), cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), 3, cv2.LINE_AA)
            cv2.putText(out, str(int(k)), (x, y), cv2.FONT_HERSHEY_SIMPLEX, scale, (255, 255, 255), 1, cv2.LINE_AA)
    return out


def _png_b64(img: np.ndarray) -> str:
    import cv2

    arr = np.asarray(img)
    if arr.ndim == 3:
        arr = cv2.cvtColor(arr, cv2.COLOR_RGB2BGR)
    ok, buf = cv2.imencode(".png", arr)
    return base64.b64encode(buf.tobytes()).decode()


_VIEWER_JS = r"""
(function(){
const data = JSON.parse(document.getElementById('cloud-data').textContent);
const cv = document.getElementById('cloud'); const ctx = cv.getContext('2d');
const P = data.points, C = data.colors, n = P.length / 3;
let cx=0, cy=0, cz=0; for (let i=0;i<n;i++){cx+=P[3*i];cy+=P[3*i+1];cz+=P[3*i+2];}
cx/=Math.max(n,1); cy/=Math.max(n,1); cz/=Math.max(n,1);
let r=1e-9; for (let i=0;i<n;i++){r=Math.max(r,Math.hypot(P[3*i]-cx,P[3*i+1]-cy,P[3*i+2]-cz));}
let yaw=0.6, pitch=-0.9, zoom=1.0, drag=null;
function draw(){
  const W=cv.width, H=cv.height, s=zoom*0.45*Math.min(W,H)/r;
  const cyw=Math.cos(yaw), syw=Math.sin(yaw), cp=Math.cos(pitch), sp=Math.sin(pitch);
  const idx=new Array(n), zs=new Float32Array(n), xs=new Float32Array(n), ys=new Float32Array(n);
  for (let i=0;i<n;i++){
    const x=P[3*i]-cx, y=P[3*i+1]-cy, z=P[3*i+2]-cz;
    const x1=cyw*x-syw*y, y1=syw*x+cyw*y;
    const y2=cp*y1-sp*z, z2=sp*y1+cp*z;
    xs[i]=W/2+s*x1; ys[i]=H/2-s*z2; zs[i]=y2; idx[i]=i;
  }
  idx.sort((a,b)=>zs[b]-zs[a]);
  ctx.fillStyle='#111'; ctx.fillRect(0,0,W,H);
  for (const i of idx){ ctx.fillStyle='rgb('+C[3*i]+','+C[3*i+1]+','+C[3*i+2]+')'; ctx.fillRect(xs[i]-1,ys[i]-1,2.5,2.5); }
}
cv.addEventListener('mousedown',e=>{drag=[e.clientX,e.clientY];});
window.addEventListener('mouseup',()=>{drag=null;});
window.addEventListener('mousemove',e=>{ if(!drag) return; yaw+=(e.clientX-drag[0])*0.01; pitch+=(e.clientY-drag[1])*0.01; drag=[e.clientX,e.clientY]; draw(); });
cv.addEventListener('wheel',e=>{ e.preventDefault(); zoom*=Math.exp(-e.deltaY*0.001); draw(); }, {passive:false});
draw();
})();
"""


def render_report(
    *,
    title: str,
    view_names: Sequence[str],
    overlays: Sequence[np.ndarray],
    points: np.ndarray,
    point_colors: np.ndarray,
    metrics: dict[str, Any] | None,
    summary: dict[str, Any],
    max_points: int = 60_000,
    rng: Any = 0,
    audit: dict[str, Any] | None = None,
) -> str:
    """The report page as a string (see the module docstring)."""
    gen = np.random.default_rng(rng)
    pts = np.asarray(points, np.float32)
    cols = np.asarray(point_colors, np.uint8)
    if len(pts) > max_points:
        sel = np.sort(gen.choice(len(pts), max_points, replace=False))
        pts, cols = pts[sel], cols[sel]
    cloud = json.dumps({"points": np.round(pts, 4).ravel().tolist(), "colors": cols.ravel().tolist()})
    rows = ""
    if metrics:
        keys = ["iou", "f1", "precision", "recall", "chamfer", "iou_sel"]
        head = "".join(f"<th>{k}</th>" for k in ["object", *keys])
        body = ""
        for o in metrics.get("objects", []):
            name = html.escape(str(o.get("name", o["id"])))
            body += "<tr><td>" + name + "</td>" + "".join(f"<td>{_fmt(o.get(k))}</td>" for k in keys) + "</tr>"
        mean = metrics.get("mean", {})
        body += "<tr class='mean'><td>mean</td>" + "".join(f"<td>{_fmt(mean.get(k))}</td>" for k in keys) + "</tr>"
        rows = f"<h2>Metrics</h2><table>{head}{body}</table><p>pixel utility: {_fmt(mean.get('pixel_utility'))}</p>"
        if metrics.get("num_pred") is not None:
            pq = ""
            if mean.get("pq") is not None:
                pq = f"; panoptic quality {_fmt(mean['pq'])} (SQ {_fmt(mean.get('sq'))} &times; RQ {_fmt(mean.get('rq'))}: extra and missed objects count)"
            rows += f"<p>objects: {int(metrics['num_pred'])} predicted, {int(metrics.get('num_gt', 0))} true{pq}</p>"
    if audit is not None:  # optional edge audit section (the data of graphseg.audit.audit)
        from .render_audit import audit_html

        rows += audit_html(audit)
    items = "".join(
        f"<figure><img src='data:image/png;base64,{_png_b64(img)}'/><figcaption>{html.escape(n)}</figcaption></figure>"
        for n, img in zip(view_names, overlays)
    )
    info = "".join(f"<li><b>{html.escape(str(k))}</b>: {html.escape(str(v))}</li>" for k, v in summary.items())
    return f"""<!doctype html>
<html><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>
body{{font-family:system-ui,sans-serif;margin:1.5em;background:#fafafa;color:#222}}
table{{border-collapse:collapse}} td,th{{border:1px solid #ccc;padding:3px 8px;text-align:right}}
tr.mean{{font-weight:bold}} figure{{display:inline-block;margin:4px}} img{{max-width:420px}}
canvas{{border:1px solid #444;cursor:grab}}
</style></head><body>
<h1>{html.escape(title)}</h1><ul>{info}</ul>
{rows}
<h2>3D objects</h2><p>Drag to rotate, scroll to zoom. Colours are object ids.</p>
<canvas id="cloud" width="900" height="600"></canvas>
<script type="application/json" id="cloud-data">{cloud}</script>
<h2>Views</h2>{items}
<script>{_VIEWER_JS}</script>
</body></html>
"""


def _fmt(v: Any) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.4g}"
    return html.escape(str(v))
