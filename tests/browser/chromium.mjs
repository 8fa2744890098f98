// Starts Debian's Chromium headless through playwright-core (which downloads no browser of its
// own), with the flags this project's machines need: no sandbox (root), no GPU, and nothing
// that reaches the network on its own (the machines' closed network refuses it).
// Every launch gets a fresh, empty profile directory: playwright makes one of its own for each
// launch (it refuses a --user-data-dir argument) and deletes it on close.
// CHROMIUM overrides the executable (default /usr/bin/chromium).
import { createRequire } from 'node:module';

const require = createRequire(import.meta.url);
const { chromium } = require('playwright-core');

export async function launch(extraArgs = []) {
  const browser = await chromium.launch({
    executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync',
      ...extraArgs],
  });
  const close = () => browser.close().catch(() => {});
  return { browser, close };
}
