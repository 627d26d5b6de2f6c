// "Erase my last": what the page's Backspace and a headset's erase button do, as the native
// window and headset do (src/session/include/volcast/session/erase_last.hpp; its test runs these
// cases). A press erases the newest annotation this page drew; one it sent that has not come back
// numbered yet (0x51) is waited for, up to ERASE_WAIT_MS (one the server refused never comes
// back), so a quick press after drawing erases what was just drawn and not the one before it.
export const ERASE_WAIT_MS = 3000;

export class EraseLast {
  constructor() {
    this.unconfirmed = [];  // {tag, atMs}: sent, not yet back numbered
    this.pressedMs = null;  // a press waits since then
  }
  // This page sent an annotation with `tag` (session.annotate's; 0: nothing sent) at `nowMs`
  // (performance.now(), as every call's).
  sent(tag, nowMs) {
    if (tag) this.unconfirmed.push({tag, atMs: nowMs});
  }
  // The key or button went down; a second press while one waits is the same press.
  pressed(nowMs) {
    if (this.pressedMs === null) this.pressedMs = nowMs;
  }
  get waiting() { return this.pressedMs !== null; }
  // Once a frame, with the session's annotations (an iterable of {id, author, tag}) and this
  // page's participant id: the id to erase now, or null (the press is done when it returns an id,
  // or null because this page drew none standing).
  due(annotations, ownId, nowMs) {
    if (this.pressedMs === null && !this.unconfirmed.length) return null;  // most frames: no copy
    const all = [...annotations];
    this.unconfirmed = this.unconfirmed.filter(
        (s) => nowMs - s.atMs <= ERASE_WAIT_MS &&
               !all.some((a) => a.author === ownId && a.tag === s.tag));
    if (this.pressedMs === null) return null;
    if (this.unconfirmed.some((s) => s.atMs <= this.pressedMs)) return null;
    this.pressedMs = null;
    const mine = all.filter((a) => a.author === ownId);
    return mine.length ? mine.reduce((x, y) => (y.id > x.id ? y : x)).id : null;
  }
}
