// Ask before an action that cannot be undone, inside the page (no browser dialog): the question,
// what will happen, and two buttons; `onYes` runs only on the explicit yes.
import { html, render } from "./html.js";

export function confirmInline(box, question, effect, yesLabel, onYes) {
  render(
    box,
    html`<div class="confirm" role="alertdialog" aria-label="${question}">
      <p><b>${question}</b> ${effect}</p>
      <button class="danger" data-confirm="yes">${yesLabel}</button>
      <button data-confirm="no">Cancel</button>
    </div>`,
  );
  box.querySelector('[data-confirm="no"]').addEventListener("click", () => render(box, ""));
  box.querySelector('[data-confirm="yes"]').addEventListener("click", async () => {
    render(box, "");
    await onYes();
  });
  box.querySelector('[data-confirm="no"]').focus();
}
