// Maps: a map view (its layout.meta.map holds the origin) is drawn as the server sends it, a plain
// projected map in metres with a scale bar and a north arrow; when the server has a basemap
// (LDVSURVEY_BASEMAP_TILE_URL, GET /api/basemap) the same points (each trace's meta.lat/lon) are
// drawn on its tiles, with a scale bar for the current zoom and north up. A toggle switches back
// to the plain map (e.g. when the network is off).
import { api } from "./api.js";
import { html, render } from "./html.js";

let basemapSetting = null;
export function basemap() {
  if (!basemapSetting) basemapSetting = api("/api/basemap").catch(() => ({ tile_url: null, attribution: "" }));
  return basemapSetting;
}

export const isMap = (fig) => Boolean(fig.layout && fig.layout.meta && fig.layout.meta.map);

// metres per pixel of a web-Mercator map at a latitude and zoom (256-px tiles)
export const metresPerPixel = (latDeg, zoom) => (156543.03392 * Math.cos((latDeg * Math.PI) / 180)) / 2 ** zoom;

// a round length (1, 2 or 5 × 10^k m) near `target` metres
export function niceLength(target) {
  const k = 10 ** Math.floor(Math.log10(Math.max(target, 1e-3)));
  return [1, 2, 5, 10].map((c) => c * k).reduce((a, b) => (Math.abs(b - target) < Math.abs(a - target) ? b : a));
}

export function onBasemap(fig, bm, widthPx = 900, heightPx = 450) {
  const lat = [],
    lon = [];
  const data = fig.data
    .filter((t) => t.meta && t.meta.lat)
    .map((t) => {
      t.meta.lat.forEach((v, i) => {
        if (v !== null) {
          lat.push(v);
          lon.push(t.meta.lon[i]);
        }
      });
      const marker = t.marker ? { ...t.marker } : undefined;
      return { type: "scattermap", mode: t.mode, name: t.name, lat: t.meta.lat, lon: t.meta.lon, marker, line: t.line };
    });
  const [la0, la1] = [Math.min(...lat), Math.max(...lat)];
  const [lo0, lo1] = [Math.min(...lon), Math.max(...lon)];
  const cLat = (la0 + la1) / 2;
  // the zoom that fits the extent (web Mercator, 256-px tiles), a little margin
  const spanX = Math.max(lo1 - lo0, 1e-6) * 1.3,
    spanY = Math.max(la1 - la0, 1e-6) * 1.3;
  const zx = Math.log2((widthPx * 360) / (256 * spanX));
  const zy = Math.log2((heightPx * 360) / ((256 * spanY) / Math.cos((cLat * Math.PI) / 180)));
  const style = {
    version: 8,
    sources: { base: { type: "raster", tiles: [bm.tile_url], tileSize: 256, attribution: bm.attribution || "" } },
    layers: [{ id: "base", type: "raster", source: "base" }],
  };
  return {
    data,
    layout: {
      title: fig.layout.title,
      margin: { t: fig.layout.margin.t, r: 20, b: 60, l: 20 },
      legend: fig.layout.legend,
      meta: fig.layout.meta,
      map: { style, center: { lat: cLat, lon: (lo0 + lo1) / 2 }, zoom: Math.min(zx, zy, 19), bearing: 0, pitch: 0 },
    },
  };
}

// the scale bar and north arrow drawn over a basemap, kept true to the current zoom
export function mapOverlay(el) {
  const box = el.parentNode.querySelector(".map-overlay") || el.parentNode.appendChild(document.createElement("div"));
  box.className = "map-overlay";
  const update = () => {
    const m = el._fullLayout && el._fullLayout.map;
    if (!m) return render(box, "");
    const mpp = metresPerPixel(m.center.lat, m.zoom);
    const len = niceLength(120 * mpp);
    const px = len / mpp;
    render(
      box,
      html`<div class="north" title="north is up">N<br />↑</div>
        <div class="scalebar" data-metres="${len}">
          <span style="width: ${px.toFixed(1)}px"></span> ${len < 1000 ? `${len} m` : `${len / 1000} km`}
        </div>`,
    );
  };
  update();
  if (!el.dataset.overlay) {
    el.dataset.overlay = "1";
    el.on("plotly_relayout", update);
  }
}
