// One context per shown page: its timers stop and its late answers are dropped when the page changes.
let current = null;

class PageContext {
  constructor() {
    this.alive = true;
    this.timers = [];
  }
  // fn() every ms while the page is shown; stops when fn returns false
  every(fn, ms) {
    const tick = async () => {
      if (!this.alive) return;
      let again = true;
      try {
        again = (await fn()) !== false;
      } catch (e) {
        /* the next tick retries */
      }
      if (this.alive && again) this.timers.push(setTimeout(tick, ms));
    };
    this.timers.push(setTimeout(tick, ms));
  }
  stop() {
    this.alive = false;
    this.timers.forEach(clearTimeout);
    this.timers = [];
  }
}

export function newPage() {
  if (current) current.stop();
  current = new PageContext();
  return current;
}
