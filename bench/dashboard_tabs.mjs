// Holds N dashboard tabs open in headless Chromium for S seconds (bench/dashboard_cost.py).
// Prints READY once every tab shows the fleet and has drawn samples.
//   node bench/dashboard_tabs.mjs URL N S
import { launch } from '../tests/browser/chromium.mjs';

const [url, n, seconds] = [process.argv[2], Number(process.argv[3] || 3), Number(process.argv[4] || 30)];
// Background tabs are throttled by Chromium; a dashboard on three monitors is not.
const { browser, close } = await launch(['--disable-background-timer-throttling',
  '--disable-renderer-backgrounding', '--disable-backgrounding-occluded-windows']);
const pages = [];
for (let i = 0; i < n; i++) {
  const page = await browser.newPage({ viewport: { width: 1400, height: 1000 } });
  await page.goto(url);
  pages.push(page);
}
for (const page of pages) {
  await page.waitForFunction(() => window.__handgate && window.__handgate.connected
    && (window.__handgate.frames.samples || 0) > 10, null, { timeout: 30000 });
}
console.log('READY');
await new Promise((r) => setTimeout(r, seconds * 1000));
await close();
