// Holds N dashboard tabs open in headless Chromium for S seconds (bench/dashboard_cost.py).
// Prints READY once every tab shows the fleet and is receiving samples.
//   node bench/dashboard_tabs.mjs URL N S
import { createRequire } from 'node:module';
import { mkdtempSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';

const root = join(dirname(fileURLToPath(import.meta.url)), '..');
const require = createRequire(join(root, 'tests', 'browser', 'package.json'));
const { chromium } = require('playwright-core');

const [url, n, seconds] = [process.argv[2], Number(process.argv[3] || 3), Number(process.argv[4] || 30)];
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
    '--disable-background-networking', '--disable-component-update', '--disable-sync',
    `--user-data-dir=${mkdtempSync(join(tmpdir(), 'handgate-bench-'))}`,
    // Background tabs are throttled by Chromium; a dashboard on three monitors is not.
    '--disable-background-timer-throttling', '--disable-renderer-backgrounding',
    '--disable-backgrounding-occluded-windows'],
});
const pages = [];
for (let i = 0; i < n; i++) {
  const page = await browser.newPage({ viewport: { width: 1600, height: 1000 } });
  await page.goto(url);
  pages.push(page);
}
for (const page of pages) {
  await page.waitForFunction(() => window.__handgate && window.__handgate.connected
    && window.__handgate.frames && (window.__handgate.frames.samples || 0) > 10, null, { timeout: 30000 });
}
console.log('READY');
await new Promise((r) => setTimeout(r, seconds * 1000));
await browser.close();
