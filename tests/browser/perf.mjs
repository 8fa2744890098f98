// How smoothly the dashboard draws and what it costs the browser (docs/dashboard.md,
// "Measuring the page"): opens the page of a running gateway in headless Chromium, waits until
// every chart plots, then for S seconds counts the frames that drew, each chart's redraws and
// the time spent drawing (window.__handgate), the renderer's main-thread busy time (Chrome
// DevTools Protocol Performance.getMetrics) and the CPU time of every Chromium process
// (/proc/<pid>/stat of this script's descendants). Prints one JSON object.
//
//   node tests/browser/perf.mjs URL [SECONDS=20] [WIDTHxHEIGHT=1400x1000]
import { readFileSync, readdirSync } from 'node:fs';
import { launch } from './chromium.mjs';

const [url, seconds = '20', size = '1400x1000'] = process.argv.slice(2);
if (!url) throw new Error('usage: node tests/browser/perf.mjs URL [SECONDS] [WIDTHxHEIGHT]');
const [width, height] = size.split('x').map(Number);
const tick = 100; // USER_HZ: clock ticks per second in /proc/<pid>/stat on Linux

/** utime + stime (s) of all descendants of `root` (not `root` itself: this node process). */
function treeCpu(root) {
  const kids = new Map();
  const cpu = new Map();
  for (const name of readdirSync('/proc')) {
    if (!/^\d+$/.test(name)) continue;
    let stat;
    try {
      stat = readFileSync(`/proc/${name}/stat`, 'utf8');
    } catch (e) {
      continue;
    }
    const f = stat.slice(stat.lastIndexOf(')') + 2).split(' ');
    const pid = Number(name);
    const ppid = Number(f[1]);
    cpu.set(pid, (Number(f[11]) + Number(f[12])) / tick);
    if (!kids.has(ppid)) kids.set(ppid, []);
    kids.get(ppid).push(pid);
  }
  let total = -(cpu.get(root) || 0);
  const todo = [root];
  while (todo.length) {
    const p = todo.pop();
    total += cpu.get(p) || 0;
    todo.push(...(kids.get(p) || []));
  }
  return total;
}

const { browser, close } = await launch();
try {
  const page = await browser.newPage({ viewport: { width, height } });
  const cdp = await page.context().newCDPSession(page);
  await cdp.send('Performance.enable');
  await page.goto(url);
  await page.waitForFunction(() => {
    const h = window.__handgate;
    return h && h.connected && h.devices().length > 0 && h.devices().every((d) => h.plotted(d, 0) !== null);
  }, null, { timeout: 30000 });
  const pid = process.pid; // Chromium runs as this script's child
  const snap = async () => {
    const m = Object.fromEntries((await cdp.send('Performance.getMetrics')).metrics.map((x) => [x.name, x.value]));
    const h = await page.evaluate(() => {
      const k = window.__handgate;
      return { t: performance.now(), drawFrames: k.drawFrames, drawMs: k.drawMs, samples: k.frames.samples,
        redraws: { ...k.redraws } };
    });
    return { m, h, cpu: treeCpu(pid), wall: process.hrtime.bigint() };
  };
  const a = await snap();
  await page.evaluate(() => { window.__handgate.drawMsMax = 0; });
  await page.waitForFunction((t) => performance.now() >= t, a.h.t + Number(seconds) * 1000,
    { timeout: (Number(seconds) + 30) * 1000, polling: 250 });
  const b = await snap();
  const drawMsMax = await page.evaluate(() => window.__handgate.drawMsMax);
  const wall = Number(b.wall - a.wall) / 1e9;
  const per = (x) => Math.round((x / wall) * 10) / 10;
  const redraws = Object.fromEntries(Object.keys(b.h.redraws)
    .map((d) => [d, per(b.h.redraws[d] - (a.h.redraws[d] || 0))]));
  const frames = b.h.drawFrames - a.h.drawFrames;
  console.log(JSON.stringify({
    url, seconds: Math.round(wall * 10) / 10, viewport: size,
    devices: Object.keys(redraws).length,
    samples_per_s: per(b.h.samples - a.h.samples),
    drawing_frames_per_s: per(frames),
    chart_redraws_per_s: redraws,
    draw_ms_mean: Math.round(((b.h.drawMs - a.h.drawMs) / Math.max(1, frames)) * 100) / 100,
    draw_ms_max: Math.round(drawMsMax * 100) / 100,
    renderer_main_thread_busy_pct: Math.round(((b.m.TaskDuration - a.m.TaskDuration) / wall) * 1000) / 10,
    renderer_script_pct: Math.round(((b.m.ScriptDuration - a.m.ScriptDuration) / wall) * 1000) / 10,
    chromium_all_processes_cpu_pct: Math.round(((b.cpu - a.cpu) / wall) * 1000) / 10,
  }));
} finally {
  await close();
}
