// cncjs (its server, headless) driving `fuzzy-send serve` through its pty,
// as its web UI would: over cncjs's socket.io API.
//
// node cncjs.js --cncjs http://127.0.0.1:PORT --port /path/to/pty
//
// Each step acts through cncjs and checks the controller's side through the
// Grbl status reports and `$#` answers cncjs relays. Exit 0: every step
// passed.
'use strict';

const http = require('http');
const io = require('socket.io-client');

const args = {};
for (let i = 2; i + 1 < process.argv.length; i += 2) {
  args[process.argv[i].replace(/^--/, '')] = process.argv[i + 1];
}
const URL_ = args.cncjs;
const PORT = args.port;
// The simulated probe plate's machine z (--plate), the axis step (--step),
// or QEMU's input socket to trip the probe by hand (--trip).
const PLATE = args.plate !== undefined ? Number(args.plate) : null;
const STEP = Number(args.step || 0.01);
const TRIP = args.trip || null;
if (!URL_ || !PORT) {
  console.error('usage: node cncjs.js --cncjs http://127.0.0.1:PORT --port /path/to/pty');
  process.exit(2);
}

function log(...a) {
  console.log('[cncjs]', ...a);
}

function signin() {
  const u = new URL('/api/signin', URL_);
  return new Promise((resolve, reject) => {
    const req = http.request(u, { method: 'POST' }, (res) => {
      let body = '';
      res.on('data', (d) => { body += d; });
      res.on('end', () => {
        try {
          resolve(JSON.parse(body).token);
        } catch (e) {
          reject(new Error(`signin: ${res.statusCode} ${body}`));
        }
      });
    });
    req.on('error', reject);
    req.end();
  });
}

// What cncjs has told us so far.
const seen = {
  state: null, // controller:state's status
  stateAt: 0, // when it last changed
  settings: null, // controller:settings (parameters from `$#`)
  workflow: 'idle',
  sender: null,
  reads: [], // serialport:read lines
  errors: [], // error: and ALARM: lines
  spindleMax: 0, // the highest spindle speed a status report showed
};

// QEMU's input word (bit 0 e-stop, 1-6 limits, 7 probe; 1 active), one
// byte to its USART2 socket.
let inputs = null;
function setInputs(word) {
  return new Promise((resolve, reject) => {
    const write = () => inputs.write(Buffer.from([word]), (e) => (e ? reject(e) : resolve()));
    if (inputs) return write();
    inputs = require('net').connect(TRIP, write);
    inputs.on('error', reject);
  });
}

function sleep(ms) {
  return new Promise((r) => setTimeout(r, ms));
}

async function until(what, timeoutMs, pred) {
  const t0 = Date.now();
  for (;;) {
    const v = pred();
    if (v) return v;
    if (Date.now() - t0 > timeoutMs) {
      throw new Error(`timed out waiting for ${what}; last status ${JSON.stringify(seen.state)}`);
    }
    await sleep(20);
  }
}

function pos(p) {
  return `${p.x},${p.y},${p.z}`;
}

// Idle, and no status change for `quietMs` (cncjs relays a status only
// when it differs): the machine has stopped.
async function settled(what, timeoutMs = 20000, quietMs = 800) {
  await until(what, timeoutMs, () => seen.state
    && seen.state.activeState === 'Idle'
    && Date.now() - seen.stateAt > quietMs);
  return seen.state;
}

function expectPos(what, got, want) {
  if (pos(got) !== want) throw new Error(`${what}: MPos ${pos(got)}, want ${want}`);
  log(`${what}: MPos ${pos(got)}`);
}

function noErrors(what) {
  if (seen.errors.length) {
    throw new Error(`${what}: cncjs relayed ${JSON.stringify(seen.errors)}`);
  }
}

async function main() {
  // The server takes a few seconds to start.
  let token;
  for (let i = 0; ; i++) {
    try {
      token = await signin();
      break;
    } catch (e) {
      if (i >= 300) throw e;
      await sleep(100);
    }
  }
  const socket = io.connect(URL_, { query: `token=${token}`, reconnection: false });
  const emit = (...a) => socket.emit(...a);
  const command = (...a) => socket.emit('command', PORT, ...a);

  socket.on('controller:state', (type, state) => {
    if (state && state.status) {
      seen.state = state.status;
      seen.spindleMax = Math.max(seen.spindleMax, Number(state.status.spindle) || 0);
      seen.stateAt = Date.now();
    }
  });
  socket.on('controller:settings', (type, settings) => { seen.settings = settings; });
  socket.on('workflow:state', (s) => { seen.workflow = s; });
  socket.on('sender:status', (s) => { seen.sender = s; });
  socket.on('serialport:read', (line) => {
    seen.reads.push(line);
    if (/^(error:|ALARM:)/.test(line)) seen.errors.push(line);
  });
  socket.on('serialport:error', (e) => { seen.errors.push(`serialport:error ${JSON.stringify(e)}`); });

  await new Promise((resolve, reject) => {
    socket.on('startup', resolve);
    socket.on('connect_error', reject);
    socket.on('error', reject);
  });
  await new Promise((resolve, reject) => {
    emit('open', PORT, { controllerType: 'Grbl', baudrate: 115200, rtscts: false }, (err) => {
      if (err) reject(new Error(`open ${PORT}: ${JSON.stringify(err)}`));
      else resolve();
    });
  });
  log(`opened ${PORT}`);
  const start = await settled('a first status');
  log(`connected: ${start.activeState} at ${pos(start.mpos)}`);

  // Load a program, start it, wait for cncjs to end the job (it does once
  // its sender is done and the machine has been idle for a while).
  async function runJob(name, gcode, during) {
    await new Promise((resolve, reject) => {
      command('gcode:load', name, gcode, {}, (err) => (err ? reject(new Error(`load: ${err}`)) : resolve()));
    });
    seen.workflow = 'idle';
    command('gcode:start');
    await until(`${name} to start`, 30000, () => seen.workflow === 'running');
    if (during) await during();
    await until(`${name} to end`, 120000, () => seen.workflow === 'idle');
    const s = seen.sender;
    if (!s || s.received !== s.total || s.sent !== s.total) {
      throw new Error(`${name}: sender ${JSON.stringify(s)}`);
    }
    log(`${name}: ${s.total} lines sent and answered in ${s.elapsedTime} ms`);
    return settled(`${name} at rest`);
  }

  // A line through cncjs's feeder; MPos once the tool has moved and
  // stopped.
  async function move(line) {
    const from = pos(seen.state.mpos);
    command('gcode', line);
    await until(line, 30000, () => pos(seen.state.mpos) !== from);
    return (await settled(`${line} at rest`)).mpos;
  }

  const steps = [
    ['a job: square, arc, dwell, spindle', async () => {
      const gcode = [
        'G21 G90 G94',
        'G0 X0 Y0 Z1',
        'M3 S1000',
        'G4 P0.2',
        'G1 Z-0.5 F300',
        'G1 X10 F1000',
        'G1 Y10',
        'G3 X0 Y10 I-5 J0',
        'G1 Y0',
        'G0 Z1',
        'M5',
        'G0 X2.5 Y3.25',
        'M30',
      ].join('\n');
      seen.spindleMax = 0;
      const s = await runJob('square.nc', gcode);
      expectPos('the end', s.mpos, '2.500,3.250,1.000');
      if (seen.spindleMax !== 1000 || Number(s.spindle) !== 0) {
        throw new Error(`spindle: at most ${seen.spindleMax} rpm during the job, ${s.spindle} at its end`);
      }
    }],
    ['feed hold and cycle start in a longer job', async () => {
      const lines = ['G21 G90 G1 F1000'];
      for (let i = 0; i < 6; i++) lines.push(`X${i % 2 ? 2 : 30} Y${4 + i}`);
      lines.push('G0 X4 Y6 Z2');
      const s = await runJob('zigzag.nc', lines.join('\n'), async () => {
        await until('motion', 40000, () => seen.state.activeState === 'Run' && seen.state.mpos.x !== '2.500');
        command('feedhold');
        const held = await until('Hold', 30000, () => seen.state.activeState === 'Hold' && seen.state);
        await until('the hold to complete', 30000, () => seen.state.subState === 0 || seen.state.subState === '0');
        const at = pos(seen.state.mpos);
        await sleep(1000);
        if (pos(seen.state.mpos) !== at || seen.state.activeState !== 'Hold') {
          throw new Error(`moved while held: ${at} then ${pos(seen.state.mpos)} ${seen.state.activeState}`);
        }
        log(`held at ${at} (${held.activeState}:${seen.state.subState})`);
        command('cyclestart');
        await until('Run again', 30000, () => seen.state.activeState === 'Run');
      });
      expectPos('the end', s.mpos, '4.000,6.000,2.000');
    }],
    ['stop a job (cncjs stop: feed hold, then soft reset), then a move', async () => {
      const lines = ['G21 G90 G1 F1000'];
      for (let i = 0; i < 6; i++) lines.push(`X${i % 2 ? 4 : 30} Y${6 + i}`);
      await new Promise((resolve, reject) => {
        command('gcode:load', 'stop.nc', lines.join('\n'), {}, (err) => (err ? reject(new Error(`load: ${err}`)) : resolve()));
      });
      command('gcode:start');
      await until('motion', 30000, () => seen.state.activeState === 'Run' && Number(seen.state.mpos.x) > 6);
      command('gcode:stop', { force: true });
      await until('the job to stop', 30000, () => seen.workflow === 'idle');
      const stopped = await settled('the stop at rest');
      if (Number(stopped.mpos.x) >= 30 || stopped.mpos.z !== '2.000') {
        throw new Error(`stopped at ${pos(stopped.mpos)}`);
      }
      log(`stopped at ${pos(stopped.mpos)}`);
      expectPos('after G0 X4 Y6', await move('G90 G0 X4 Y6'), '4.000,6.000,2.000');
    }],
    ['a jog', async () => {
      const before = seen.state.mpos;
      command('gcode', '$J=G91 X5 F1000');
      await until('the jog', 40000, () => seen.state.mpos.x !== before.x);
      const s = await settled('the jog at rest');
      expectPos('after $J=G91 X5', s.mpos, '9.000,6.000,2.000');
    }],
    ['jog cancel, then a jog at once (continuous jogging); feed override', async () => {
      command('gcode', '$J=G91 X20 F150');
      await until('the jog', 30000, () => Number(seen.state.mpos.x) > 9);
      command('jogCancel');
      command('gcode', '$J=G91 Y2 F1000');
      await until('the second jog', 30000, () => seen.state.mpos.y === '8.000');
      const s = await settled('the jogs at rest');
      const x = Number(s.mpos.x);
      if (!(x > 9 && x < 29) || s.mpos.y !== '8.000' || s.mpos.z !== '2.000') {
        throw new Error(`after the cancel and the second jog: MPos ${pos(s.mpos)}`);
      }
      log(`cancelled at X ${s.mpos.x}, then Y+2: MPos ${pos(s.mpos)}`);
      // cncjs's override buttons (0x91, 0x90).
      command('feedOverride', 10);
      await until('Ov:110', 30000, () => seen.state.ov && seen.state.ov[0] === 110);
      command('feedOverride', 0);
      await until('Ov:100', 30000, () => seen.state.ov && seen.state.ov[0] === 100);
      expectPos('after G0 X9 Y6', await move('G90 G0 X9 Y6'), '9.000,6.000,2.000');
    }],
    ['work zero on Z (G10 L20 P1 Z0), read back by $#', async () => {
      command('gcode', 'G10 L20 P1 Z0');
      command('gcode', '$#');
      const g54 = await until('[G54:] from $#', 30000, () => {
        const p = seen.settings && seen.settings.parameters && seen.settings.parameters.G54;
        return p && Number(p.z) !== 0 && p;
      });
      if (Number(g54.z) !== 2 || Number(g54.x) !== 0 || Number(g54.y) !== 0) {
        throw new Error(`G54 ${JSON.stringify(g54)}, want 0,0,2`);
      }
      const s = await until('WCO in a status report', 30000, () => seen.state.wpos.z === '0.000' && seen.state);
      log(`G54 ${g54.x},${g54.y},${g54.z}; WPos ${pos(s.wpos)}, MPos ${pos(s.mpos)}`);
      expectPos('work zero', s.mpos, '9.000,6.000,2.000');
    }],
    ['a Z probe as the Probe widget of cncjs sends it, then a work zero on the plate', async () => {
      const before = seen.state.mpos;
      const fromZ = Number(before.z);
      let tripped = null;
      if (TRIP) {
        // QEMU: the probe input (bit 7 of the input word on USART2) set
        // once the tool has gone 1 mm down.
        tripped = until('the probe move', 30000, () => seen.state.activeState === 'Run'
          && Number(seen.state.mpos.z) < fromZ - 1).then(() => setInputs(0x80));
      }
      // The widget's commands for a Z probe: relative, G38.2 at the probe
      // feed, absolute, the plate's thickness as the work zero, retract.
      command('gcode', ['G91', 'G38.2 Z-10 F100', 'G90', 'G10 L20 P1 Z0.5', 'G91', 'G0 Z2', 'G90'].join('\n'));
      const prb = await until('[PRB:] relayed by cncjs', 60000, () => {
        // ($# earlier reported the last probe, none yet: result 0.)
        const p = seen.settings && seen.settings.parameters && seen.settings.parameters.PRB;
        return p && Number(p.result) === 1 ? p : null;
      });
      if (tripped) {
        await tripped;
        await setInputs(0x00);
      }
      const z = Number(prb.z);
      if (prb.x !== before.x || prb.y !== before.y) {
        throw new Error(`PRB ${JSON.stringify(prb)} from ${pos(before)}`);
      }
      if (PLATE !== null && Math.abs(z - PLATE) > STEP + 1e-9) {
        throw new Error(`PRB z ${z}, the plate is at ${PLATE} (one step ${STEP})`);
      }
      if (!(z < fromZ - 1 && z > fromZ - 10)) throw new Error(`PRB z ${z} from ${fromZ}`);
      const s = await settled('the retract at rest');
      // G10 L20 took the position the probe move stopped at (the trip, or
      // past it by its deceleration), 2 mm below the retract's end.
      const stop = Number(s.mpos.z) - 2;
      if (!(stop <= z + 1e-9 && stop > z - 0.1)) throw new Error(`stopped at ${stop}, PRB z ${z}`);
      command('gcode', '$#');
      const g54 = await until(`[G54:] from $# with z ${stop - 0.5}`, 30000, () => {
        const p = seen.settings && seen.settings.parameters && seen.settings.parameters.G54;
        return p && Math.abs(Number(p.z) - (stop - 0.5)) < 1e-6 ? p : null;
      });
      log(`probed at ${prb.x},${prb.y},${prb.z}; G54 ${g54.x},${g54.y},${g54.z}; MPos ${pos(s.mpos)}`);
    }],
  ];

  for (const [name, run] of steps) {
    const t0 = Date.now();
    log(`-- ${name}`);
    await run();
    noErrors(name);
    log(`ok: ${name} (${Date.now() - t0} ms)`);
  }

  await new Promise((resolve) => emit('close', PORT, resolve));
  socket.close();
  if (inputs) inputs.end();
}

const deadline = setTimeout(() => {
  console.error('[cncjs] FAIL: overall deadline');
  process.exit(1);
}, Number(args.deadline || 120) * 1000);

main().then(() => {
  clearTimeout(deadline);
  log('PASS');
  process.exit(0);
}, (e) => {
  console.error(`[cncjs] FAIL: ${e.message}`);
  console.error(`[cncjs] last lines: ${JSON.stringify(seen.reads.slice(-15))}`);
  process.exit(1);
});
