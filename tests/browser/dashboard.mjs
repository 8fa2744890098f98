// Drives handgate's dashboard in headless Chromium for tests/tests/dashboard.rs, one step at a
// time: the test writes one JSON request per line on stdin, this script answers each with one
// line on stdout, `OK <json>` or `ERR <message>`. It prints `READY` once the browser runs.
// Every wait is on the page's state (waitForFunction / selectors) with a deadline, never a
// sleep. Errors the page throws and its console errors are collected and returned by `state`.
//
//   node tests/browser/dashboard.mjs        (CHROMIUM=/path overrides /usr/bin/chromium)
//
// Requests ({"op": ..., ...}):
//   open {url}                       load the page; wait for hello and samples on every chart
//   goto {url}                       load url in a fresh browser context (no cookie); its HTTP
//                                    status, final URL, whether it is the token form, the cookies
//   login {token}                    type the token in the form goto showed and submit it; then
//                                    as ready (the page with its cookie, the URL without the token)
//   ready {timeout_ms}               wait (without reloading) until connected and plotting again
//   state                            connection, counters, cards, controls, page errors
//   hello                            the hello frame the page read
//   plotted {device, joint}          window.__handgate.plotted(device, joint)
//   wait_plotted {device, joint, lo, hi, timeout_ms}
//                                    wait until lo <= plotted <= hi
//   wait_conn {text, timeout_ms}     wait until #conn reads text
//   set_closure {device, value}      move the device's closure slider
//   command {device, on}             switch the device's "command" toggle
//   safe {device}                    press the device's "safe" button
//   wait_pads {device, timeout_ms}   wait until a pads frame reached the device's map; state
//   wait_refused {device, timeout_ms}
//                                    wait until the device's card shows a refusal; its text
//   wait_text {selector, contains, timeout_ms}
//                                    wait until the element's text contains `contains`; its text
//   quit
import { createInterface } from 'node:readline';
import { launch } from './chromium.mjs';

const { browser, close } = await launch();
const pageErrors = [];
// Each page is in a context of its own (browser.newPage): its own cookies.
async function newPage() {
  const p = await browser.newPage({ viewport: { width: 1400, height: 1000 } });
  p.on('pageerror', (e) => pageErrors.push(`pageerror: ${e.message}`));
  p.on('console', (m) => {
    // The token form is answered with 401, which Chromium reports as a console error.
    if (m.type() === 'error' && !m.text().includes('401')) pageErrors.push(`console.error: ${m.text()}`);
  });
  return p;
}
let page = await newPage();

const card = (device) => `article.card[data-device="${device}"]`;

async function state() {
  const s = await page.evaluate(() => {
    const h = window.__handgate;
    return {
      connected: h ? h.connected : false,
      conn: document.querySelector('#conn')?.textContent ?? null,
      devices: h ? h.devices() : [],
      cards: [...document.querySelectorAll('article.card[data-device]')].map((e) => e.dataset.device),
      rows: [...document.querySelectorAll('#fleet tbody tr[data-row]')].map((e) => e.dataset.row),
      controls: document.querySelectorAll('[data-control]').length,
      padMaps: [...document.querySelectorAll('article.card[data-device] .pads canvas')]
        .map((e) => e.closest('article').dataset.device),
      pads: h && h.hello ? Object.fromEntries(h.devices().map((d) => [d, h.pads(d)])) : {},
      controlsByDevice: Object.fromEntries([...document.querySelectorAll('article.card[data-device]')]
        .map((e) => [e.dataset.device, [...e.querySelectorAll('[data-control]')].map((c) => c.dataset.control)])),
      frames: h ? { ...h.frames } : null,
      sent: h ? h.sent : null,
      closes: h ? h.closes : null,
      fps: h ? h.fps : null,
      redraws: h ? { ...h.redraws } : null,
      refused: h ? h.refused.slice() : [],
      commands: h && h.hello ? h.hello.commands : null,
    };
  });
  s.pageErrors = pageErrors.slice();
  s.url = page.url();
  return s;
}

/** Waits until fn(arg) is truthy in the page; on timeout fails with describe() and the state. */
async function waitFn(fn, arg, timeout, describe) {
  try {
    await page.waitForFunction(fn, arg, { timeout, polling: 100 });
  } catch (e) {
    throw new Error(`${await describe()} within ${timeout} ms (${e.message.split('\n')[0]}): `
      + JSON.stringify(await state()));
  }
}

const ops = {
  async open({ url, timeout_ms = 60000 }) {
    await page.goto(url, { timeout: timeout_ms });
    return ops.ready({ timeout_ms });
  },
  async goto({ url, timeout_ms = 60000 }) {
    await page.context().close();
    page = await newPage();
    const r = await page.goto(url, { timeout: timeout_ms });
    return {
      status: r ? r.status() : null,
      url: page.url(),
      form: await page.locator('form input[name="token"]').count(),
      dashboard: await page.evaluate(() => window.__handgate !== undefined),
      cookies: (await page.context().cookies()).map((c) => c.name),
    };
  },
  async login({ token, timeout_ms = 60000 }) {
    await page.locator('form input[name="token"]').fill(token);
    // The form opens ?token=..., which the server answers with the cookie and a redirect:
    // one navigation of the main frame, to the URL without the token.
    await Promise.all([
      page.waitForEvent('framenavigated', { predicate: (f) => f === page.mainFrame(), timeout: timeout_ms }),
      page.locator('form button[type="submit"]').click(),
    ]);
    await page.waitForLoadState('load', { timeout: timeout_ms });
    const s = await ops.ready({ timeout_ms });
    s.cookies = (await page.context().cookies()).map((c) => ({
      name: c.name, httpOnly: c.httpOnly, sameSite: c.sameSite,
    }));
    s.scriptSeesCookie = await page.evaluate(() => document.cookie.includes('handgate_token'));
    return s;
  },
  async ready({ timeout_ms = 60000 }) {
    // Connected, and every device's chart has been handed samples.
    await waitFn(() => {
      const h = window.__handgate;
      return h && h.connected && h.devices().length > 0
        && h.devices().every((d) => h.plotted(d, 0) !== null) && h.frames.status > 0;
    }, null, timeout_ms, () => 'the page did not connect and plot every device');
    return state();
  },
  state,
  async hello() {
    return page.evaluate(() => window.__handgate.hello);
  },
  async plotted({ device, joint }) {
    return page.evaluate(([d, j]) => window.__handgate.plotted(d, j), [device, joint]);
  },
  async wait_plotted({ device, joint, lo, hi, timeout_ms = 60000 }) {
    await waitFn(([d, j, a, b]) => {
      const v = window.__handgate.plotted(d, j);
      return typeof v === 'number' && v >= a && v <= b;
    }, [device, joint, lo, hi], timeout_ms, async () =>
      `plotted(${device}, ${joint}) did not reach [${lo}, ${hi}] (last ${await ops.plotted({ device, joint })})`);
    return ops.plotted({ device, joint });
  },
  async wait_conn({ text, timeout_ms = 60000 }) {
    await waitFn((t) => document.querySelector('#conn')?.textContent === t, text, timeout_ms,
      () => `#conn did not read ${JSON.stringify(text)}`);
    return state();
  },
  async set_closure({ device, value }) {
    await page.locator(`${card(device)} input[data-control="closure"]`).fill(String(value));
    return page.locator(`${card(device)} input[data-control="closure"]`).inputValue();
  },
  async command({ device, on }) {
    const toggle = page.locator(`${card(device)} input[data-control="command"]`);
    if (on) await toggle.check();
    else await toggle.uncheck();
    return toggle.isChecked();
  },
  async safe({ device }) {
    await page.locator(`${card(device)} [data-control="safe"]`).click();
    return state();
  },
  async wait_text({ selector, contains, timeout_ms = 60000 }) {
    await waitFn(([sel, c]) => (document.querySelector(sel)?.textContent || '').includes(c),
      [selector, contains], timeout_ms, async () =>
        `${selector} did not contain ${JSON.stringify(contains)} (it reads ${JSON.stringify(
          await page.evaluate((sel) => document.querySelector(sel)?.textContent ?? null, selector))})`);
    return page.evaluate((sel) => document.querySelector(sel).textContent, selector);
  },
  async wait_pads({ device, timeout_ms = 60000 }) {
    await waitFn((d) => window.__handgate.pads(d) !== null, device, timeout_ms,
      () => `no pads frame for ${device}`);
    return state();
  },
  async wait_refused({ device, timeout_ms = 60000 }) {
    const line = page.locator(`${card(device)} .refused`);
    await waitFn((sel) => (document.querySelector(sel)?.textContent || '').length > 0,
      `${card(device)} .refused`, timeout_ms, () => `${device}'s card showed no refusal`);
    return line.textContent();
  },
};

console.log('READY');
const rl = createInterface({ input: process.stdin });
for await (const line of rl) {
  if (!line.trim()) continue;
  let req;
  try {
    req = JSON.parse(line);
  } catch (e) {
    console.log(`ERR not JSON: ${line}`);
    continue;
  }
  if (req.op === 'quit') break;
  const f = ops[req.op];
  if (!f) {
    console.log(`ERR unknown op ${req.op}`);
    continue;
  }
  try {
    const r = await f(req);
    console.log(`OK ${JSON.stringify(r === undefined ? null : r)}`);
  } catch (e) {
    console.log(`ERR ${String(e.message || e).replace(/\n/g, ' ')}`);
  }
}
await close();
