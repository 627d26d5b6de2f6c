// What the page shows over its picture (index.html, style.css): the overlay line (top left: the
// stream, the tier and path, the session, the connection), the people panel (top right: each
// other participant's voice state and volume slider) and the recording badge (bottom centre:
// who records and since when, never silently). It reads the page's state (app.js `state`,
// window.volcast), the Session (session.js) and the Voice (voice.js, once made) and writes only
// the DOM and `state.session.recording` (an error in the overlay is app.js's fail).

export class Panels {
  // `voice()`: the page's Voice or null; `nowServerUs()`: the server's clock as the page estimates
  // it (µs); `pushToTalk`: the fragment's ptt=1.
  constructor({state, session, voice, nowServerUs, pushToTalk}) {
    Object.assign(this, {state, session, voice, nowServerUs, pushToTalk});
    this.overlay = document.getElementById('overlay');
    this.people = document.getElementById('people');
    this.recording = document.getElementById('recording');
    this.peopleRows = new Map();  // participant id -> {label, slider, value}
    this.at = 0;                  // when the overlay was last written (ms)
  }

  // The overlay and the people panel, at most twice a second unless `now` (a change to show).
  update(now = false) {
    const t = performance.now();
    if (now) this.at = 0;
    if (t - this.at < 500 || this.state.phase === 'error') return;
    this.at = t;
    const state = this.state, session = this.session;
    const median = (a) => (a.length ? [...a].sort((x, y) => x - y)[a.length >> 1] : 0);
    const names = [...session.others.values()].map((p) => p.name).join(', ') || 'nobody yet';
    if (state.connection) {
      this.overlay.textContent = state.connection.toUpperCase().slice(0, 12) + state.connection.slice(12);
      this.overlay.className = 'reconnecting';
      return;
    }
    this.overlay.className = '';
    const last = state.tierChanges[state.tierChanges.length - 1];
    this.overlay.textContent =
        `${state.cameras} camera(s), tier ${state.tier}` +
        `${state.losslessDepth ? '' : ' (LOSSY DEPTH)'}${state.adaptive ? ' adaptive' : ' pinned'}` +
        (state.pathMbit ? ` · path ~${state.pathMbit.toFixed(1)} Mbit/s` : '') +
        (last ? ` · ${last.notice ? 'kept' : '→'} ${last.tier}: ${last.reason}` : '') +
        (state.outages.length ? ` · reconnected ${state.outages.length}×` : '') +
        ` · ${state.framesReceived} frame sets · ` +
        `decode ${median(state.decodeMs).toFixed(1)} ms · ` +
        (state.photonMs.length ? `to photon ${median(state.photonMs).toFixed(0)} ms · ` : '') +
        (session.joined ? `in '${session.joined.name}' with ${names}` : 'joining…') +
        (session.error ? ` · ${session.error}` : '') +
        (state.blend.reason ? ` · ${state.blend.reason}` : '') + this.voiceLine();
    this.updatePeople();
  }

  // Whether the room is being recorded (Session.recording, 0x53): shown until it stops. In an
  // immersive session, a red box in the headset's view says it (room_boxes.js recordingBadge).
  showRecording() {
    const r = this.session.recording;
    this.state.session.recording = {...r};
    this.recording.hidden = !r.recording;
    if (!r.recording) return;
    const since = new Date((r.sinceUs - this.nowServerUs() + Date.now() * 1000) / 1000);
    this.recording.textContent = `REC · recorded by ${r.by}, since ` +
        since.toLocaleTimeString([], {hour: '2-digit', minute: '2-digit'});
  }

  // The people panel: each other participant with its voice's state (green: speaking, red: muted)
  // and a volume slider (0-400 %, as the desktop panel's) that sets the gain their voice plays at
  // here.
  updatePeople() {
    const voice = this.voice();
    if (!voice || !voice.ctx) return;
    const present = new Set();
    for (const p of this.session.others.values()) {
      present.add(p.id);
      let row = this.peopleRows.get(p.id);
      if (!row) {
        const label = document.createElement('span');
        const slider = document.createElement('input');
        Object.assign(slider, {type: 'range', min: '0', max: '4', step: '0.05'});
        slider.dataset.name = p.name;
        slider.setAttribute('aria-label', `volume of ${p.name}`);
        const value = document.createElement('span');
        slider.addEventListener('input', () => {
          voice.setVolume(p.id, Number(slider.value));
          value.textContent = `${Math.round(slider.value * 100)}%`;
        });
        row = {label, slider, value};
        this.people.append(label, slider, value);
        this.peopleRows.set(p.id, row);
      }
      const gain = voice.volume(p.id, p.name);
      if (document.activeElement !== row.slider) {
        row.slider.value = String(gain);
        row.value.textContent = `${Math.round(gain * 100)}%`;
      }
      row.label.textContent = p.name + (p.muted ? ' (muted)' : '');
      row.label.className = p.muted ? 'muted' : voice.speaking(p.id) ? 'speaking' : '';
    }
    for (const [id, row] of this.peopleRows) {
      if (present.has(id)) continue;
      row.label.remove();
      row.slider.remove();
      row.value.remove();
      this.peopleRows.delete(id);
    }
    this.people.hidden = this.peopleRows.size === 0;
  }

  // The overlay's voice part: the microphone's state and who speaks.
  voiceLine() {
    const voice = this.voice(), v = this.state.voice;
    if (!voice || !v) return '';
    if (v.error) return ` · voice: ${v.error}`;
    const mic = !v.mic ? 'listening' : v.muted ? 'muted (M)' :
        this.pushToTalk ? (v.talking ? 'talking' : 'hold V to talk') : 'mic on (M mutes)';
    const speaking = [...this.session.others.values()].filter((p) => voice.speaking(p.id))
        .map((p) => p.name);
    return ` · ${mic}` + (speaking.length ? ` · speaking: ${speaking.join(', ')}` : '');
  }
}
