// Plotly is large: it is fetched only when a page has a plot (and warmed up after first paint).
let loading = null;

export function plotly() {
  if (window.Plotly) return Promise.resolve(window.Plotly);
  if (!loading) {
    loading = new Promise((resolve, reject) => {
      const s = document.createElement("script");
      s.src = "/vendor/plotly.min.js";
      s.async = true;
      s.onload = () => resolve(window.Plotly);
      s.onerror = () => {
        loading = null;
        reject(new Error("could not load the plotting library"));
      };
      document.head.appendChild(s);
    });
  }
  return loading;
}

export async function draw(el, data, layout) {
  const P = await plotly();
  if (!el.isConnected) return null; // the page changed meanwhile
  await P.react(el, data, layout, { responsive: true, displaylogo: false });
  return el;
}

export function warmUp() {
  const idle = window.requestIdleCallback || ((f) => setTimeout(f, 300));
  idle(() => plotly().catch(() => {}));
}
