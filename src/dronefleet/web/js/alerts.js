// Alarms as an operator needs them (issue 14): a readable toast for every alarm, and a beep for
// the ones that need a person now (a CRITICAL alarm, a drone lost), with a mute toggle.
//
// The beep is made with the Web Audio API (an oscillator, no sound file): a library such as
// howler.js adds sprites and formats we do not need. Browsers refuse to start audio before the
// person has touched the page (autoplay policy), and Chromium logs a warning when a page tries:
// the AudioContext is created only on the first click or key press, and an alarm before that is
// shown (toast, and the mute button says sound is waiting for a click) but not played.
import { toast } from "./ui.js";

const MUTE_KEY = "dronefleet.muted";
const state = { audio: null, muted: localStorage.getItem(MUTE_KEY) === "1", beeps: 0, button: null };

/** The stream message as an alarm to announce, or null: {text, loud}. */
export function alarmOf(msg) {
  if (msg.kind === "alarm") {
    const d = msg.data || {};
    const level = d.level || "ALARM";
    return { text: `alarm from ${msg.drone_id}: ${level} ${d.message || d.alarm || ""}`.trim(), loud: level === "CRITICAL" };
  }
  if (msg.kind === "fleet" && msg.data && msg.data.event === "lost") {
    return { text: `drone ${msg.drone_id} lost: no heartbeat`, loud: true };
  }
  return null;
}

/** Show (and, when it needs a person now, sound) the alarm in a stream message, if any. */
export function announce(msg) {
  const alarm = alarmOf(msg);
  if (!alarm) return;
  toast(alarm.text, "error");
  if (alarm.loud) beep();
}

function unlock() {
  if (state.audio) return;
  const Context = window.AudioContext || window.webkitAudioContext;
  if (!Context) return;
  state.audio = new Context();
  render();
}

/** Three short square-wave pulses at 880 Hz: heard over wind and rotors, not a melody. */
function beep() {
  if (state.muted || !state.audio) {
    render();
    return;
  }
  const ctx = state.audio;
  if (ctx.state === "suspended") ctx.resume();
  const start = ctx.currentTime + 0.02;
  for (let i = 0; i < 3; i += 1) {
    const t = start + i * 0.25;
    const osc = ctx.createOscillator();
    const gain = ctx.createGain();
    osc.type = "square";
    osc.frequency.value = 880;
    gain.gain.setValueAtTime(0.0001, t);
    gain.gain.exponentialRampToValueAtTime(0.25, t + 0.01);
    gain.gain.exponentialRampToValueAtTime(0.0001, t + 0.15);
    osc.connect(gain).connect(ctx.destination);
    osc.start(t);
    osc.stop(t + 0.16);
  }
  state.beeps += 1;
  render();
}

function render() {
  const b = state.button;
  if (!b) return;
  b.setAttribute("aria-pressed", String(state.muted));
  b.textContent = state.muted ? "Alarm sound: off" : "Alarm sound: on";
  b.title = state.muted
    ? "Critical alarms and lost drones are not sounded"
    : state.audio ? "Critical alarms and lost drones beep" : "Sound starts after your first click or key press (browser rule)";
  b.dataset.audio = state.audio ? "ready" : "waiting";
  b.dataset.beeps = String(state.beeps);
}

/** Wire the mute toggle (a button) and wait for the first gesture to allow sound. */
export function installAlerts(button) {
  state.button = button;
  button.addEventListener("click", () => {
    state.muted = !state.muted;
    localStorage.setItem(MUTE_KEY, state.muted ? "1" : "0");
    render();
  });
  for (const kind of ["pointerdown", "keydown"]) document.addEventListener(kind, unlock, { once: true, capture: true });
  render();
}
