// End-to-end test of `throng serve` in a real headless Chromium (Debian's /usr/bin/chromium,
// driven by playwright-core): the page opens and draws frames, a screenshot shows agents in their
// group colour, a click on the canvas moves the field's goal (checked through GET /state), the
// Pause button stops the frame number, and an error from the server is shown on the page; an
// open world (the bottleneck) is fitted on load, the legend names the groups, and a flock's
// page offers only the click modes that act on it.
//
//   node tests/browser/e2e.mjs [--bin target/release/throng] [--modules DIR/node_modules]
//                              [--screenshot FILE.png] [--perf [--agents N] [--seconds S] [--threads T]]
//
// --screenshot writes the page (after the goal click) to FILE.png; --perf instead streams a
// flock of N agents (default 100,000) to the tab and prints the frames per second it drew.
// scripts/e2e-setup installs Chromium and playwright-core; scripts/test-all runs this file.

import { spawn } from "node:child_process";
import { mkdtempSync, readFileSync, readdirSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join, resolve } from "node:path";
import { pathToFileURL } from "node:url";
import { inflateSync } from "node:zlib";

const argv = process.argv.slice(2);
const opt = (name, fallback) => {
  const i = argv.indexOf(name);
  return i >= 0 && i + 1 < argv.length ? argv[i + 1] : fallback;
};
const flag = (name) => argv.includes(name);
const root = resolve(new URL("../..", import.meta.url).pathname);
const target = process.env.CARGO_TARGET_DIR || join(root, "target");
const bin = resolve(opt("--bin", process.env.THRONG_BIN || join(target, "release", "throng")));
const modules = resolve(opt("--modules", join(target, "e2e", "node_modules")));
const screenshotPath = opt("--screenshot", null);
const CHROMIUM = "/usr/bin/chromium";
const AGENT_RGB = [255, 99, 71]; // the first group's colour, as the page and the PNG renderer draw it

const { chromium } = await import(pathToFileURL(join(modules, "playwright-core", "index.mjs")).href);

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
let passed = 0, failed = 0;
const cleanups = [];

async function check(name, body) {
  const start = Date.now();
  try {
    await body();
    passed++;
    console.log(`ok   ${name} (${Date.now() - start} ms)`);
  } catch (e) {
    failed++;
    console.log(`FAIL ${name}: ${e.stack || e}`);
  }
}

function assert(cond, message) {
  if (!cond) throw new Error(message);
}

async function until(what, f, timeout = 20000) {
  const start = Date.now();
  for (;;) {
    const v = await f();
    if (v) return v;
    if (Date.now() - start > timeout) throw new Error(`timed out waiting for ${what}`);
    await sleep(50);
  }
}

/** Starts `throng serve ARGS --port 0` and resolves to its base URL. */
function serve(args) {
  return new Promise((resolveUrl, reject) => {
    const child = spawn(bin, ["serve", ...args, "--port", "0"], { stdio: ["ignore", "pipe", "pipe"] });
    cleanups.push(() => child.kill("SIGINT"));
    let out = "", err = "";
    child.stdout.on("data", (d) => {
      out += d;
      const m = out.match(/serving (http:\/\/127\.0\.0\.1:\d+\/)/);
      if (m) resolveUrl({ url: m[1], child });
    });
    child.stderr.on("data", (d) => { err += d; });
    child.on("exit", (code) => reject(new Error(`throng serve exited (${code}): ${err}`)));
  });
}

async function getJson(url) {
  const r = await fetch(url);
  return r.json();
}

let profile = null;

/** CPU seconds (user + system) of every Chromium process of this test's profile, on Linux. */
function chromiumCpuSeconds() {
  let ticks = 0;
  for (const pid of readdirSync("/proc").filter((d) => /^\d+$/.test(d))) {
    try {
      if (!readFileSync(`/proc/${pid}/cmdline`, "utf8").includes(profile)) continue;
      const stat = readFileSync(`/proc/${pid}/stat`, "utf8"), fields = stat.slice(stat.lastIndexOf(")") + 2).split(" ");
      ticks += Number(fields[11]) + Number(fields[12]);
    } catch { /* the process ended */ }
  }
  return ticks / 100; // USER_HZ
}

async function launch() {
  profile = mkdtempSync(join(tmpdir(), "throng-e2e-"));
  cleanups.push(() => rmSync(profile, { recursive: true, force: true }));
  const context = await chromium.launchPersistentContext(profile, {
    executablePath: CHROMIUM,
    headless: true,
    viewport: { width: 1280, height: 800 },
    args: ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--disable-background-networking",
      "--disable-component-update", "--disable-sync", "--no-first-run"],
  });
  cleanups.push(() => context.close());
  return context;
}

/** Decodes an 8-bit RGB or RGBA, non-interlaced PNG (what Chromium's screenshots are). */
function decodePng(buf) {
  let at = 8, width = 0, height = 0, type = 0;
  const idat = [];
  while (at < buf.length) {
    const len = buf.readUInt32BE(at), kind = buf.toString("ascii", at + 4, at + 8), data = buf.subarray(at + 8, at + 8 + len);
    if (kind === "IHDR") {
      width = data.readUInt32BE(0); height = data.readUInt32BE(4); type = data[9];
      assert(data[8] === 8 && (type === 2 || type === 6) && data[12] === 0, "an 8-bit RGB(A) non-interlaced PNG");
    } else if (kind === "IDAT") idat.push(data);
    at += 12 + len;
  }
  const bpp = type === 6 ? 4 : 3, stride = width * bpp, raw = inflateSync(Buffer.concat(idat));
  const px = Buffer.alloc(stride * height);
  for (let y = 0; y < height; y++) {
    const f = raw[y * (stride + 1)], src = y * (stride + 1) + 1, dst = y * stride;
    for (let x = 0; x < stride; x++) {
      const a = x >= bpp ? px[dst + x - bpp] : 0, b = y ? px[dst - stride + x] : 0, c = x >= bpp && y ? px[dst - stride + x - bpp] : 0;
      const p = a + b - c, pa = Math.abs(p - a), pb = Math.abs(p - b), pc = Math.abs(p - c);
      const pred = [0, a, b, (a + b) >> 1, pa <= pb && pa <= pc ? a : pb <= pc ? b : c][f];
      px[dst + x] = (raw[src + x] + pred) & 255;
    }
  }
  return { width, height, bpp, px };
}

function countColour(png, rgb, tolerance = 10) {
  let n = 0;
  for (let i = 0; i < png.px.length; i += png.bpp) {
    if (Math.abs(png.px[i] - rgb[0]) <= tolerance && Math.abs(png.px[i + 1] - rgb[1]) <= tolerance && Math.abs(png.px[i + 2] - rgb[2]) <= tolerance) n++;
  }
  return n;
}

/** A free cell of field 0 whose 5 x 5 block is all free, nearest the grid's centre. */
function openCell(world) {
  const f = world.fields[0], L = f.layer, cells = Buffer.from(L.cells, "base64");
  const free = (x, y) => x >= 0 && y >= 0 && x < L.width && y < L.height && cells[y * L.width + x] < 255;
  let best = null;
  for (let y = 2; y < L.height - 2; y++) {
    for (let x = 2; x < L.width - 2; x++) {
      let ok = true;
      for (let dy = -2; dy <= 2 && ok; dy++) for (let dx = -2; dx <= 2 && ok; dx++) ok = free(x + dx, y + dy);
      const d = Math.hypot(x - L.width / 2, y - L.height / 2);
      if (ok && (!best || d < best.d)) best = { x: x * L.step, y: y * L.step, d };
    }
  }
  assert(best, "the field has an open cell");
  const s = f.cell_size;
  return { cell: [best.x, best.y], point: [f.origin[0] + (best.x + 0.5) * s, f.origin[1] + (best.y + 0.5) * s] };
}

async function endToEnd() {
  const { url } = await serve(["fields", "--seed", "3"]);
  const context = await launch();
  const page = context.pages()[0] || (await context.newPage());
  const pageErrors = [];
  page.on("pageerror", (e) => pageErrors.push(String(e)));
  await page.goto(url);

  await check("the page opens and draws frames", async () => {
    await until("20 frames drawn", () => page.evaluate(() => window.throng && window.throng.stats.drawn > 20 && window.throng.stats.received > 5));
    const f = await page.evaluate(() => window.throng.frame());
    assert(f.n === 1000, `1000 agents in the frame, not ${f.n}`);
    assert(await page.locator("canvas#view").isVisible(), "the canvas is visible");
  });

  await check("the screenshot shows agents in their group colour", async () => {
    const png = decodePng(await page.screenshot());
    const agents = countColour(png, AGENT_RGB);
    assert(agents >= 150, `only ${agents} pixels of the agent colour`);
    assert(agents < png.width * png.height * 0.2, `${agents} agent-coloured pixels: the page is flooded`);
  });

  await check("a click on the canvas moves the field's goal", async () => {
    const world = await getJson(url + "world");
    const before = await getJson(url + "state");
    const { cell, point } = openCell(world);
    const [px, py] = await page.evaluate(([x, y]) => window.throng.worldToPage(x, y), point);
    await page.mouse.click(px, py);
    const after = await until("the goal to move", async () => {
      const s = await getJson(url + "state");
      return JSON.stringify(s.goals) !== JSON.stringify(before.goals) && s;
    });
    assert(after.goals.length === 1, `one goal after the click: ${JSON.stringify(after.goals)}`);
    const [gx, gy] = after.goals[0];
    assert(Math.abs(gx - cell[0]) <= 1 && Math.abs(gy - cell[1]) <= 1, `goal ${gx},${gy} where the click was (${cell})`);
    await until("the page to show the new goal", () => page.evaluate(() => window.throng.state() && window.throng.state().goals.length === 1));
    if (screenshotPath) {
      await sleep(4000);
      await page.screenshot({ path: screenshotPath });
      console.log(`wrote ${screenshotPath}`);
    }
  });

  await check("Pause stops the frame number and Play resumes it", async () => {
    await page.click("#play");
    const paused = await until("the server to pause", async () => { const s = await getJson(url + "state"); return s.paused && s; });
    await sleep(600);
    const later = await getJson(url + "state");
    assert(later.frame === paused.frame, `frame ${paused.frame} became ${later.frame} while paused`);
    const shown = await until("the page to show the pause", () => page.evaluate(() => { const f = window.throng.frame(); return f.paused && f; }));
    assert(shown.frame === paused.frame, `the page shows frame ${shown.frame}, the server holds ${paused.frame}`);
    assert((await page.textContent("#play")) === "Play", "the button offers Play");
    await page.click("#step");
    await until("one step", async () => (await getJson(url + "state")).frame === paused.frame + 1);
    await page.click("#play");
    await until("frames again", async () => (await getJson(url + "state")).frame > paused.frame + 5);
  });

  await check("an error from the server is shown on the page", async () => {
    await page.fill("#spf", "5000");
    await page.dispatchEvent("#spf", "change");
    await until("the error box", () => page.evaluate(() => {
      const e = document.getElementById("error");
      return e.style.display === "block" && e.textContent.includes("1000");
    }));
    const s = await getJson(url + "state");
    assert(s.steps_per_frame === 1, "the bad value changed nothing");
  });

  await check("the page raised no script errors", async () => {
    assert(pageErrors.length === 0, pageErrors.join("\n"));
  });
}

/** `throng serve bottleneck` (an open world) and `flock`: the view fits the world when it loads,
 * the legend names the groups, and only click modes that act in the scene are offered. */
async function firstLook() {
  const context = await launch();
  const page = await context.newPage();
  const pageErrors = [];
  page.on("pageerror", (e) => pageErrors.push(String(e)));
  const { url } = await serve(["bottleneck", "--paused"]);
  await page.goto(url);
  await check("an open world is fitted when the page loads", async () => {
    await until("a frame drawn", () => page.evaluate(() => window.throng && window.throng.stats.drawn >= 1 && window.throng.frame()));
    const world = await getJson(url + "world");
    const [x0, y0, x1, y1] = world.extent;
    const cam = await page.evaluate(() => window.throng.camera());
    const [w, h] = [(x1 - x0) * cam.scale, (y1 - y0) * cam.scale];
    assert(w <= cam.width + 1 && h <= cam.height + 1, `the extent (${w} x ${h} px) overflows the ${cam.width} x ${cam.height} canvas`);
    assert(w >= 0.9 * cam.width || h >= 0.9 * cam.height, `the world is ${w.toFixed(0)} x ${h.toFixed(0)} px on a ${cam.width} x ${cam.height} canvas`);
    assert(Math.abs(cam.cx - (x0 + x1) / 2) < 1e-3 && Math.abs(cam.cy - (y0 + y1) / 2) < 1e-3, "the world is centred");
  });
  await check("the pedestrian page offers goal, wall and circle, and names its group", async () => {
    const shown = await page.evaluate(() => [...document.querySelectorAll("input[name=mode]")]
      .filter((r) => r.parentElement.style.display !== "none").map((r) => r.value));
    assert(JSON.stringify(shown) === JSON.stringify(["goal", "wall", "circle"]), `modes offered: ${shown}`);
    const legend = (await page.textContent("#legend")).trim();
    assert(legend === "occupants", `legend "${legend}"`);
  });
  const flock = await serve(["flock", "--agents", "300", "--paused"]);
  await page.goto(flock.url);
  await check("a flock's page offers no gravity or goal mode and starts in one that acts", async () => {
    await until("a frame drawn", () => page.evaluate(() => window.throng && window.throng.stats.drawn >= 1 && window.throng.frame()));
    const shown = await page.evaluate(() => [...document.querySelectorAll("input[name=mode]")]
      .filter((r) => r.parentElement.style.display !== "none").map((r) => r.value));
    assert(JSON.stringify(shown) === JSON.stringify(["wall", "circle"]), `modes offered: ${shown}`);
    assert((await page.evaluate(() => window.throng.mode())) === "wall", "the default mode is wall");
    const legend = (await page.textContent("#legend")).trim();
    assert(!/^\d/.test(legend), `the legend "${legend}" reads as a count`);
  });
  await check("the first-look pages raised no script errors", async () => {
    assert(pageErrors.length === 0, pageErrors.join("\n"));
  });
}

async function perf() {
  const agents = opt("--agents", "100000"), seconds = Number(opt("--seconds", "10"));
  const threads = opt("--threads", null);
  const { url } = await serve(["flock", "--agents", agents, ...(threads ? ["--threads", threads] : [])]);
  // The same run without a browser first: how fast it steps on this machine right now.
  await sleep(2000);
  const b0 = await getJson(url + "state"), t0 = performance.now();
  await sleep(seconds * 1000);
  const b1 = await getJson(url + "state"), alone = (b1.frame - b0.frame) / ((performance.now() - t0) / 1000);
  const context = await launch();
  const page = context.pages()[0] || (await context.newPage());
  await page.goto(url);
  await until("frames", () => page.evaluate(() => window.throng && window.throng.stats.drawn > 5), 60000);
  await sleep(3000);
  const read = () => page.evaluate(() => ({ ...window.throng.stats, t: performance.now() }));
  const s0 = await getJson(url + "state"), a = await read(), cpu0 = chromiumCpuSeconds();
  await sleep(seconds * 1000);
  const s1 = await getJson(url + "state"), b = await read(), cpu1 = chromiumCpuSeconds();
  const dt = (b.t - a.t) / 1000;
  const result = {
    agents: Number(agents),
    seconds: Number(dt.toFixed(2)),
    frames_drawn_per_sec: Number(((b.drawn - a.drawn) / dt).toFixed(1)),
    frames_received_per_sec: Number(((b.received - a.received) / dt).toFixed(1)),
    sim_steps_per_sec: Number(((s1.frame - s0.frame) / dt).toFixed(1)),
    sim_steps_per_sec_without_browser: Number(alone.toFixed(1)),
    ms_per_step: Number(s1.timings.ms_per_step.toFixed(2)),
    mbytes_per_sec: Number(((b.bytes - a.bytes) / dt / 1e6).toFixed(1)),
    page_draw_ms_per_frame: Number(((b.drawMs - a.drawMs) / Math.max(1, b.drawn - a.drawn)).toFixed(2)),
    chromium_cpu_ms_per_frame: Number(((cpu1 - cpu0) * 1000 / Math.max(1, b.drawn - a.drawn)).toFixed(1)),
    page_read_ms_per_frame: Number(((b.readMs - a.readMs) / Math.max(1, b.received - a.received)).toFixed(2)),
  };
  console.log(JSON.stringify(result));
  passed++;
}

const guard = setTimeout(() => { console.log("FAIL the browser test took longer than 180 s"); process.exit(1); }, 180000);
try {
  if (flag("--perf")) await perf();
  else {
    await endToEnd();
    await firstLook();
  }
} catch (e) {
  failed++;
  console.log(`FAIL ${e.stack || e}`);
} finally {
  for (const f of cleanups.reverse()) {
    try { await f(); } catch { /* already gone */ }
  }
  clearTimeout(guard);
}
console.log(`browser: ${passed} passed, ${failed} failed`);
process.exit(failed ? 1 : 0);
