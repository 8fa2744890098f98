// Screenshots of the dashboard for the docs (docs/dashboard.md, README.md): starts
// `handgate run` on the default fleet (an emulated object in dex3_left's hand, so its pads read
// pressure when it closes), moves the hands with `handgate send`, and saves
//   docs/img/dashboard.png       the whole page (read-only, as the default profile serves it)
//   docs/img/dashboard-pads.png  dex3_left's card: chart and pressure map
//
//   cargo build -p handgate && node tests/browser/screenshot.mjs [--bin PATH] [--out DIR]
//        [--domain N] [--scheme light|dark]
//
// Defaults: target/debug/handgate, docs/img, DDS domain 184 (docs/development.md), light.
import { spawn } from 'node:child_process';
import { mkdirSync, mkdtempSync, readFileSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { launch } from './chromium.mjs';

const root = resolve(dirname(fileURLToPath(import.meta.url)), '..', '..');
const arg = (name, dflt) => {
  const i = process.argv.indexOf(`--${name}`);
  return i > 0 ? process.argv[i + 1] : dflt;
};
const bin = resolve(arg('bin', join(root, 'target', 'debug', 'handgate')));
const out = resolve(arg('out', join(root, 'docs', 'img')));
const domain = arg('domain', '184');
const scheme = arg('scheme', 'light');

// The default profile, with an object in dex3_left's hand for the pads.
const anchor = 'timeout_bit = true    # the emulated motors honour the 1 s timeout-protection bit too\n';
const text = readFileSync(join(root, 'profiles', 'default.toml'), 'utf8');
if (!text.includes(anchor)) throw new Error(`profiles/default.toml no longer contains ${JSON.stringify(anchor)}`);
const dir = mkdtempSync(join(tmpdir(), 'handgate-screenshot-'));
const profile = join(dir, 'screenshot.toml');
writeFileSync(profile, text.replace(anchor, `${anchor}
[devices.emulator]
object_at = { thumb_2 = 0.3, index_1 = 0.35, middle_1 = 0.35 }
`));

/** Runs `handgate ARGS`; resolves with its exit code. */
function handgate(args, opts = {}) {
  return new Promise((res, rej) => {
    const p = spawn(bin, args, { stdio: ['ignore', 'ignore', 'inherit'], ...opts });
    p.on('error', rej);
    p.on('exit', (code) => res(code));
  });
}

// The gateway, on any free port; its url= log line says where.
const gw = spawn(bin, ['run', '--profile', profile, '--domain', domain, '--http-port', '0'],
  { stdio: ['ignore', 'pipe', 'inherit'] });
const url = await new Promise((res, rej) => {
  let buf = '';
  const t = setTimeout(() => rej(new Error(`handgate printed no url= line in 60 s:\n${buf}`)), 60000);
  gw.stdout.on('data', (d) => {
    buf += d;
    const m = /url=(http:\/\/\S+)/.exec(buf);
    if (m) {
      clearTimeout(t);
      res(m[1]);
    }
  });
  gw.on('exit', (code) => rej(new Error(`handgate exited (${code}):\n${buf}`)));
});
gw.stdout.resume();
console.log(`dashboard at ${url}`);

const { browser, close } = await launch();
try {
  const page = await browser.newPage({ viewport: { width: 1400, height: 900 }, deviceScaleFactor: 1,
    colorScheme: scheme });
  await page.goto(url);
  await page.waitForFunction(() => window.__handgate && window.__handgate.connected
    && window.__handgate.devices().every((d) => window.__handgate.plotted(d, 0) !== null));

  // Some motion on every hand, each device through its own canonical front at the same time;
  // the pictures are taken during the last, long step (the hands still commanded, dex3_left
  // pressing on its object).
  const t0 = await page.evaluate(() => window.__handgate.t);
  const send = (device, steps) => steps.reduce((p, [closure, hold]) => p.then(async () => {
    const code = await handgate(['send', device, '--domain', domain, '--closure', String(closure),
      '--hold', String(hold)]);
    if (code !== 0) throw new Error(`handgate send ${device} --closure ${closure}: exit ${code}`);
  }), Promise.resolve());
  const moving = Promise.all([
    send('dex3_left', [[0.6, 2], [0.15, 2], [1, 8]]),
    send('dex3_right', [[0.35, 1.5], [0.8, 2.5], [0.5, 8]]),
    send('dex1_left', [[0.8, 2.5], [0.3, 9.5]]),
    send('dex1_right', [[0.2, 1.5], [0.9, 10.5]]),
  ]);
  // 8 s of history on the gateway's clock, with pressure on dex3_left's pads and a status frame
  // since.
  await page.waitForFunction((t) => {
    const h = window.__handgate;
    const pads = h.pads('dex3_left');
    return h.t >= t + 8 && pads && pads.some((p) => p.some((v) => v > 0));
  }, t0, { timeout: 60000 });
  const statuses = await page.evaluate(() => window.__handgate.frames.status);
  await page.waitForFunction((n) => window.__handgate.frames.status > n, statuses);

  mkdirSync(out, { recursive: true });
  const suffix = scheme === 'dark' ? '-dark' : '';
  await page.screenshot({ path: join(out, `dashboard${suffix}.png`), fullPage: true });
  await page.locator('article.card[data-device="dex3_left"]').screenshot({ path: join(out, `dashboard-pads${suffix}.png`) });
  console.log(`wrote ${join(out, `dashboard${suffix}.png`)} and ${join(out, `dashboard-pads${suffix}.png`)}`);
  await moving;
} finally {
  await close();
  gw.kill('SIGINT');
}
