// Emulated SlimeVR trackers (npm package @slimevr/tracker-emulation) for MimuCap's tests and
// screenshots.
//
//   node slimevr_trackers.mjs MODULES_DIR --port 6969 [--host 127.0.0.1] [--trackers 3]
//        [--sensors 2] [--rate 50] [--duration 0]
//
// MODULES_DIR is the folder holding node_modules/@slimevr/tracker-emulation. Tracker t
// (0-based) has the MAC 02:4D:43:00:00:<t+1> and `--sensors` BNO085 sensors. Once connected,
// sensor s of tracker t sends its k-th rotation (k = 0, 1, ...) as the quaternion
// (x, y, z, w) = (sin h · a, cos h) with half angle h = 0.01 k + 0.2 t + 0.1 s and unit axis
// a ∝ (cos b, sin b, 0.5), b = 0.7 t + 1.3 s, so the receiver can recompute every value.
// Each tracker reports a battery of (80 − 5 t) % at 3.9 V and a signal of (−50 − t) dBm.
//
// Standard output: one JSON object per line: {"event": "connected", "tracker": t} once a
// tracker has its server, {"event": "stopped", "tracker": t, "sent": [n per sensor]} after
// "stop t" on standard input, and {"event": "done", "sent": [[n per sensor] per tracker]} at
// the end (duration over, "quit", or standard input closed).
import path from 'node:path';
import readline from 'node:readline';
import { pathToFileURL } from 'node:url';

// the packages' CommonJS builds do not load (their package.json says "type": "module"): import
// their ES module builds by path
const load = (name) => import(pathToFileURL(path.join(path.resolve(process.argv[2]), 'node_modules', '@slimevr',
  name, 'dist', 'esm', 'index.js')).href);
const { EmulatedTracker } = await load('tracker-emulation');
const { BoardType, FirmwareFeatureFlags, MCUType, RotationDataType, SensorStatus, SensorType } =
  await load('firmware-protocol');
const { MACAddress, Quaternion } = await load('common');

const options = { port: 6969, host: '127.0.0.1', trackers: 3, sensors: 2, rate: 50, duration: 0 };
for (let i = 3; i < process.argv.length; i += 2) {
  const key = process.argv[i].replace(/^--/, '');
  if (!(key in options)) throw new Error(`unknown option ${process.argv[i]}`);
  options[key] = key === 'host' ? process.argv[i + 1] : Number(process.argv[i + 1]);
}

const say = (object) => process.stdout.write(JSON.stringify(object) + '\n');

function rotation(t, s, k) {
  const h = 0.01 * k + 0.2 * t + 0.1 * s;
  const b = 0.7 * t + 1.3 * s;
  const a = [Math.cos(b), Math.sin(b), 0.5];
  const n = Math.hypot(...a);
  const sh = Math.sin(h) / n;
  return new Quaternion(sh * a[0], sh * a[1], sh * a[2], Math.cos(h));
}

const trackers = [];
for (let t = 0; t < options.trackers; t++) {
  const flags = new FirmwareFeatureFlags(new Map([['ROTATION_DATA', true]]));
  const tracker = new EmulatedTracker(new MACAddress([0x02, 0x4d, 0x43, 0, 0, t + 1]), '0.4.1-emulated', flags,
    BoardType.WROOM32, MCUType.ESP32, options.host, options.port);
  const entry = { tracker, sensors: [], sent: new Array(options.sensors).fill(0), timer: null, connected: false };
  tracker.on('error', () => {});
  tracker.on('connected-to-server', async () => {
    entry.connected = true;
    await tracker.changeBatteryLevel(3.9, 80 - 5 * t);
    await tracker.sendSignalStrength(255, -50 - t);
    say({ event: 'connected', tracker: t });
  });
  tracker.on('disconnected-from-server', () => { entry.connected = false; });
  trackers.push(entry);
}

for (const [t, entry] of trackers.entries()) {
  await entry.tracker.init();
  for (let s = 0; s < options.sensors; s++) {
    entry.sensors.push(await entry.tracker.addSensor(SensorType.BNO085, SensorStatus.OK));
  }
  entry.timer = setInterval(async () => {
    if (!entry.connected) return;
    for (const [s, sensor] of entry.sensors.entries()) {
      const k = entry.sent[s]++;
      await sensor.sendRotation(RotationDataType.NORMAL, rotation(t, s, k), 0);
    }
  }, 1000 / options.rate);
}

async function stop(t) {
  const entry = trackers[t];
  if (entry === undefined || entry.timer === null) return;
  clearInterval(entry.timer);
  entry.timer = null;
  entry.connected = false;
  await entry.tracker.deinit();
  say({ event: 'stopped', tracker: t, sent: entry.sent });
}

async function finish() {
  for (let t = 0; t < trackers.length; t++) await stop(t);
  say({ event: 'done', sent: trackers.map((e) => e.sent) });
  process.exit(0);
}

const input = readline.createInterface({ input: process.stdin });
input.on('line', async (line) => {
  const [command, arg] = line.trim().split(/\s+/);
  if (command === 'stop') await stop(Number(arg));
  else if (command === 'quit') await finish();
});
input.on('close', finish);
if (options.duration > 0) setTimeout(finish, options.duration * 1000);
