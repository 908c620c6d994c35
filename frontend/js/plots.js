// Plotly is large (1.5 MB): it is fetched only when a page draws a plot, never for lists and forms.
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
