// Speaking and playback. Live: a WebSocket streams each sentence's audio (int16 PCM) and AU
// frames as soon as the server has them; audio is scheduled with Web Audio and the animation
// follows the audio clock. Replay: an <audio> element plays the whole WAV and its currentTime
// drives the morph weights.

export class Player {
  constructor({ audio, onSentence, onState, onLatency }) {
    Object.assign(this, { audio, onSentence, onState, onLatency });
    this.segments = [];      // [{t0, fps, channels, values}]
    this.sentences = [];
    this.tl = null;          // timeline frames {fps, channels, values}
    this.mode = "idle";      // idle | live | audio | free
    this.key = null;         // cached speech on the server
    this.duration = 0;
    this.sources = [];
    this.metrics = {};
    this.nextId = 1;
    this.connect();
    this.audio.addEventListener("ended", () => { if (this.mode === "audio" && this.timelineEnd() <= this.audio.currentTime) this.stop(); });
  }

  connect() {
    const proto = location.protocol === "https:" ? "wss" : "ws";
    this.ws = new WebSocket(`${proto}://${location.host}/api/live`);
    this.ws.binaryType = "arraybuffer";
    this.wsReady = new Promise((res) => this.ws.addEventListener("open", res, { once: true }));
    this.ws.addEventListener("message", (m) => this.onMessage(m));
    this.ws.addEventListener("close", () => {
      if (this.mode === "live") { this.mode = "idle"; this.onState(this.mode); this.onError && this.onError("The connection to the studio server was lost; press Speak again."); }
      setTimeout(() => this.connect(), 1000);
    });
  }

  ctx() {
    if (!this.actx) this.actx = new AudioContext({ latencyHint: "interactive" });
    if (this.actx.state === "suspended") this.actx.resume();
    return this.actx;
  }

  // Forget the spoken text (it changed or was cleared): nothing old replays.
  clearSpeech() {
    if (this.mode === "live" || this.mode === "audio") this.stop();
    this.id = this.nextId++;  // late messages of the old text are ignored
    this.segments = []; this.sentences = []; this.duration = 0; this.key = null; this.done = false;
    this.recording = null;
    this.audio.removeAttribute("src");
    this.audio.load();
  }

  // Speech that arrived whole (a recording aligned on the server): ready for Play.
  loadSpeech(r, recording) {
    this.clearSpeech();
    this.key = r.key; this.segments = r.segments; this.sentences = r.sentences;
    this.duration = r.duration; this.done = true; this.recording = recording;
    this.audio.src = r.audio;
    this.onSentence(this.sentences);
  }

  timelineEnd() { return this.tl ? (this.tl.values.length - 1) / this.tl.fps : 0; }
  end() { return Math.max(this.duration, this.timelineEnd()); }

  async speak({ text, lang, project, blend, fps = 30 }) {
    this.stop();
    const ctx = this.ctx();   // created inside the click: allowed to play
    this.segments = []; this.sentences = []; this.duration = 0; this.key = null;
    this.liveStart = null; this.done = false;
    this.id = this.nextId++;
    this.metrics = { t_speak: performance.now(), outputLatencyMs: ((ctx.outputLatency || 0) + (ctx.baseLatency || 0)) * 1000 };
    this.mode = "live";
    this.onState(this.mode);
    if (this.ws.readyState !== WebSocket.OPEN) await this.wsReady;
    if (this.mode !== "live") return;  // stopped while connecting
    this.ws.send(JSON.stringify({ type: "speak", id: this.id, text, lang, project, blend, fps }));
    this.metrics.sentMs = performance.now() - this.metrics.t_speak;
  }

  onMessage(m) {
    if (typeof m.data !== "string") return this.onAudio(m.data);
    let msg;
    try { msg = JSON.parse(m.data); } catch { return; }
    if (msg.id !== undefined && msg.id !== this.id) return;  // a cancelled request
    if (msg.type === "start") {
      this.metrics.startMsgMs = performance.now() - this.metrics.t_speak;
    } else if (msg.type === "frames") {
      this.segments.push(msg);
      this.segments.sort((a, b) => a.t0 - b.t0);
    } else if (msg.type === "sentence") {
      this.sentences.push(msg);
      this.duration = Math.max(this.duration, msg.end);
      this.onSentence(this.sentences);
    } else if (msg.type === "done") {
      this.done = true;
      this.key = msg.key;
      this.duration = msg.duration;
      this.audio.src = msg.audio;
      this.metrics.server = msg.timing;
      this.onLatency(this.metrics);
    } else if (msg.type === "error") {
      this.mode = "idle";
      this.onState(this.mode);
      this.onError && this.onError(msg.message);
    }
  }

  onAudio(buf) {
    const n = new DataView(buf).getUint32(0, true);
    const head = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 4, n)));
    if (head.id !== this.id || this.mode !== "live") return;
    if (this.metrics.audioRecvMs === undefined) this.metrics.audioRecvMs = performance.now() - this.metrics.t_speak;
    const off = 4 + n;
    const pcm = new Int16Array(buf.slice(off));
    const ctx = this.ctx();
    const ab = ctx.createBuffer(1, pcm.length, head.sr);
    const ch = ab.getChannelData(0);
    for (let i = 0; i < pcm.length; i++) ch[i] = pcm[i] / 32768;
    if (this.liveStart === null) {
      const lead = 0.02;  // a little headroom so the first samples are not clipped
      this.liveStart = ctx.currentTime + lead;
      this.metrics.firstAudioMs = performance.now() - this.metrics.t_speak + lead * 1000;
      this.metrics.serverFirstAudioMs = head.server_ms;
      this.onLatency(this.metrics);
    }
    const src = ctx.createBufferSource();
    src.buffer = ab;
    src.connect(ctx.destination);
    src.start(this.liveStart + head.t0);
    this.sources.push(src);
  }

  // Replay the cached speech (re-mixed with the current timeline) through <audio>.
  async play(from, remix) {
    this.stop();
    if (this.key && remix) {
      const r = await remix(this.key);
      if (r) { this.segments = r.segments; this.sentences = r.sentences; this.duration = r.duration; }
      else this.clearSpeech();  // expired on the server: never replay stale frames
    }
    if (from >= this.end() - 0.05) from = 0;  // at the end: replay from the start
    if (this.key) {
      this.audio.currentTime = Math.min(from, this.duration);
      this.mode = from < this.duration ? "audio" : "free";
      if (this.mode === "audio") {
        try {
          await this.audio.play();
        } catch (e) {  // blocked or unplayable: animate without sound rather than freeze
          if (this.mode !== "audio") return;  // stopped meanwhile (pause() aborts play())
          this.playError = `${e.name}: ${e.message}`;
          this.onError && this.onError("The browser would not play the sound, so the face moves silently.");
          this.mode = "free";
        }
      }
    } else {
      this.mode = "free";
    }
    this.freeStart = performance.now() / 1000 - from;
    this.onState(this.mode);
  }

  stop() {
    for (const s of this.sources) { try { s.stop(); } catch { /* not started */ } }
    this.sources = [];
    if (!this.audio.paused) this.audio.pause();
    if (this.mode === "live" && this.ws && this.ws.readyState === WebSocket.OPEN) this.ws.send(JSON.stringify({ type: "stop" }));
    this.mode = "idle";
    this.onState && this.onState(this.mode);
  }

  // The master clock in seconds (null when nothing plays).
  clock() {
    if (this.mode === "live") return this.liveStart === null ? null : this.actx.currentTime - this.liveStart;
    if (this.mode === "audio") {
      if (this.audio.ended || this.audio.currentTime >= this.duration - 1e-3) {
        return this.audio.currentTime + (performance.now() / 1000 - (this.audioEndWall ??= performance.now() / 1000));
      }
      this.audioEndWall = undefined;
      return this.audio.currentTime;
    }
    if (this.mode === "free") return performance.now() / 1000 - this.freeStart;
    return null;
  }

  // {code: value} at time t: speech segments (already mixed with the timeline) else timeline
  frameAt(t) {
    for (const s of this.segments) {
      const n = s.values.length;
      if (t >= s.t0 && t < s.t0 + n / s.fps) return interp(s, t - s.t0);
    }
    return this.tl ? interp(this.tl, t) : {};
  }

  finished(t) {
    if (this.mode === "live") return this.done && t > this.end() + 0.1;
    return t > this.end() + 0.05;
  }
}

export function interp(tr, t) {
  const n = tr.values.length;
  if (!n) return {};
  const x = Math.max(0, Math.min(t * tr.fps, n - 1));
  const i = Math.floor(x), f = x - i, j = Math.min(i + 1, n - 1);
  const a = tr.values[i], b = tr.values[j], out = {};
  for (let k = 0; k < tr.channels.length; k++) {
    const v = a[k] + (b[k] - a[k]) * f;
    if (v > 1e-4) out[tr.channels[k]] = v;
  }
  return out;
}
