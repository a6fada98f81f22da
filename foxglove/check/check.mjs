#!/usr/bin/env node
// Headless check of a layout in the real Foxglove Studio 1.48.0 (the open-source Studio's built
// bundle from the npm registry, @foxglove/studio-base) running in Debian's Chromium via Playwright.
// How it reads Studio's state (all DOM, no Studio internals): the layout's panels by
// [data-testid="panel-mouseenter-container ID"], a Plot's series by its legend's -plotName /
// -plotValue cells (a value at the current time) and coloured pixels in the plot, a RosOut
// panel's rows, the data source's start/end time, and the "Problems" tab's list. A file is
// seeked to its end first, so the legends hold the last values.
//
//   node check.mjs --mcap FILE.mcap --layout LAYOUT.json [--screenshot OUT.png]
//   node check.mjs --ws ws://127.0.0.1:PORT --layout LAYOUT.json [--screenshot OUT.png]
//
// Options: --timeout SEC (whole-run budget, default 100), --settle SEC (default 6),
//   --full-range (drop the Plot panels' followingViewWidth so the x axis shows the whole file),
//   --allow-partial (a Plot with data on only some of its paths counts as "data"),
//   --chromium PATH (default /usr/bin/chromium), --headed, --keep-profile, --verbose.
// Prints a JSON summary on stdout. Exit 0: every panel shows data and Studio lists no problem.
// Exit 1: check failed. Exit 2: harness error/timeout. (foxglove/check/run.sh runs it in CI.)
import fs from "node:fs";
import os from "node:os";
import path from "node:path";
import { fileURLToPath } from "node:url";
import { chromium } from "playwright-core";
import { startServer } from "./serve.mjs";

const HERE = path.dirname(fileURLToPath(import.meta.url));
const T_START = Date.now();
const elapsed = () => Date.now() - T_START;

function parseArgs(argv) {
  const a = { timeout: 100, settle: 6, chromium: "/usr/bin/chromium" };
  for (let i = 0; i < argv.length; i++) {
    const k = argv[i];
    const val = () => { if (i + 1 >= argv.length) throw new Error(`${k} needs a value`); return argv[++i]; };
    if (k === "--mcap") a.mcap = val();
    else if (k === "--ws") a.ws = val();
    else if (k === "--layout") a.layout = val();
    else if (k === "--screenshot") a.screenshot = val();
    else if (k === "--timeout") a.timeout = Number(val());
    else if (k === "--settle") a.settle = Number(val());
    else if (k === "--chromium") a.chromium = val();
    else if (k === "--full-range") a.fullRange = true;
    else if (k === "--allow-partial") a.allowPartial = true;
    else if (k === "--headed") a.headed = true;
    else if (k === "--keep-profile") a.keepProfile = true;
    else if (k === "--verbose" || k === "-v") a.verbose = true;
    else if (k === "--help" || k === "-h") { console.log(fs.readFileSync(fileURLToPath(import.meta.url), "utf8").split("\n").slice(1, 20).join("\n")); process.exit(0); }
    else throw new Error(`unknown argument ${k}`);
  }
  if (!a.mcap === !a.ws) throw new Error("give exactly one of --mcap FILE or --ws URL");
  if (!a.layout) throw new Error("--layout LAYOUT.json is required");
  return a;
}

let args;
try { args = parseArgs(process.argv.slice(2)); } catch (e) { console.error(String(e.message)); process.exit(2); }
const log = (...m) => { if (args.verbose) console.error(`[${(elapsed() / 1000).toFixed(1)}s]`, ...m); };
const deadline = T_START + args.timeout * 1000;
const remaining = () => Math.max(0, deadline - Date.now());
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// ---------- layout: panels actually placed in the mosaic ----------
const layout = JSON.parse(fs.readFileSync(args.layout, "utf8"));
function panelIdsOf(node, out = []) {
  if (node == undefined) return out;
  if (typeof node === "string") { out.push(node); return out; }
  panelIdsOf(node.first, out); panelIdsOf(node.second, out);
  return out;
}
const panelIds = panelIdsOf(layout.layout);
for (const id of panelIds) {
  if (id.startsWith("Tab!")) for (const tab of layout.configById?.[id]?.tabs ?? []) panelIdsOf(tab.layout, panelIds);
}
const servedLayout = structuredClone(layout);
if (args.fullRange) for (const [id, cfg] of Object.entries(servedLayout.configById ?? {})) if (id.startsWith("Plot!")) delete cfg.followingViewWidth;

// ---------- server ----------
const studioDir = path.join(HERE, "node_modules/@foxglove/studio-base");
const tmpLayout = path.join(os.tmpdir(), `rover-power-layout-${process.pid}.json`);
fs.writeFileSync(tmpLayout, JSON.stringify(servedLayout));
const files = {
  "/index.html": path.join(HERE, "index.html"),
  "/main.js": path.join(HERE, "main.js"),
  "/layout.json": tmpLayout,
  "/vendor/react.production.min.js": path.join(HERE, "node_modules/react/umd/react.production.min.js"),
  "/vendor/react-dom.production.min.js": path.join(HERE, "node_modules/react-dom/umd/react-dom.production.min.js"),
};
let dataName;
if (args.mcap) {
  if (!fs.existsSync(args.mcap)) { console.error(`no such file ${args.mcap}`); process.exit(2); }
  dataName = path.basename(args.mcap).replace(/[^A-Za-z0-9._-]/g, "_");
  if (!dataName.endsWith(".mcap")) dataName += ".mcap";
  files[`/data/${dataName}`] = path.resolve(args.mcap);
}
const { server, port } = await startServer({ files, mounts: { "/studio/": studioDir }, log: (m) => log("http", m) });
const origin = `http://127.0.0.1:${port}`;
const LAYOUT_ID = "rover-power";
const q = new URLSearchParams();
if (args.mcap) { q.set("ds", "remote-file"); q.set("ds.url", `${origin}/data/${dataName}`); }
else { q.set("ds", "foxglove-websocket"); q.set("ds.url", args.ws); }
q.set("layoutId", LAYOUT_ID);
const pageUrl = `${origin}/index.html?${q}`;

// ---------- browser ----------
const profile = fs.mkdtempSync(path.join(os.tmpdir(), "rover-power-chromium-"));
const consoleErrors = [];
const playerProblemLogs = {};
let context;
const summary = {
  source: args.mcap ? { mcap: path.resolve(args.mcap) } : { ws: args.ws },
  layout: path.resolve(args.layout),
  studio: "@foxglove/studio-base@1.48.0",
  ok: false,
  failures: [],
};

async function cleanup() {
  try { await context?.close(); } catch {}
  server.close();
  try { fs.rmSync(tmpLayout, { force: true }); } catch {}
  if (!args.keepProfile) try { fs.rmSync(profile, { recursive: true, force: true }); } catch {}
}
const hardTimer = setTimeout(async () => {
  summary.failures.push(`harness: hard timeout after ${args.timeout + 15}s`);
  console.log(JSON.stringify(summary, null, 2));
  await cleanup(); process.exit(2);
}, (args.timeout + 15) * 1000);
hardTimer.unref();

try {
  context = await chromium.launchPersistentContext(profile, {
    executablePath: args.chromium,
    headless: !args.headed,
    args: ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
      "--disable-background-networking", "--disable-component-update", "--disable-sync",
      "--disable-dev-shm-usage"].filter((f) => !(args.headed && f === "--headless")),
    viewport: { width: 1600, height: 1000 },
    timeout: 30000,
  });
  const page = context.pages()[0] ?? (await context.newPage());
  page.setDefaultTimeout(15000);
  page.on("console", (m) => {
    const text = m.text();
    const pm = /^Player problem (\S+) /.exec(text);
    if (pm) { playerProblemLogs[pm[1]] = text.slice(0, 600); return; }
    if (m.type() === "error") consoleErrors.push(text.slice(0, 600));
  });
  page.on("pageerror", (e) => consoleErrors.push(`pageerror: ${String(e.stack ?? e).slice(0, 600)}`));
  page.on("crash", () => consoleErrors.push("page crashed"));

  log("goto", pageUrl);
  await page.goto(pageUrl, { waitUntil: "load", timeout: Math.min(30000, remaining()) });

  // 1. Studio mounted and the layout's panels are in the DOM
  await page.waitForFunction(() => window.__studio && (window.__studio.stage === "mounted" || window.__studio.stage === "failed"), null, { timeout: Math.min(30000, remaining()) });
  const mount = await page.evaluate(() => window.__studio);
  if (mount.stage !== "mounted") throw new Error(`Studio did not mount: ${mount.errors.join("; ")}`);
  await page.waitForFunction((ids) => ids.every((id) => document.querySelector(`[data-testid="panel-mouseenter-container ${id}"]`)), panelIds, { timeout: Math.min(30000, remaining()) })
    .catch(() => summary.failures.push("harness: not every layout panel appeared in the DOM (layout not selected?)"));
  summary.timing = { mountedMs: elapsed() };
  log("mounted");

  // 2. Wait for the data source to initialise (START/END shown, or a problem listed)
  const srcInfo = () => page.evaluate(() => {
    // DataSourceInfoView: <Typography variant="overline">Start time</Typography> followed by its value
    const grab = (label) => {
      const o = [...document.querySelectorAll(".MuiTypography-overline")].find((e) => e.innerText.trim().toLowerCase() === label.toLowerCase());
      const v = o?.nextElementSibling; return v ? v.innerText.replace(/\s+/g, " ").trim() || undefined : undefined;
    };
    const problemsTab = [...document.querySelectorAll('[role="tab"]')].find((t) => /^Problems/.test(t.innerText.trim()));
    return {
      currentSource: grab("CURRENT SOURCE"), startTime: grab("START TIME"), endTime: grab("END TIME"), duration: grab("DURATION"),
      problemCount: problemsTab ? Number((/(\d+)/.exec(problemsTab.innerText) ?? [0, 0])[1]) : undefined,
      playbackTime: document.querySelector('[data-testid="PlaybackTime-text"] input, input[data-testid="PlaybackTime-text"]')?.value,
    };
  });
  let info = await srcInfo();
  while (remaining() > 0 && elapsed() < 45000) {
    info = await srcInfo();
    if (args.ws ? (info.problemCount > 0 || (info.startTime && info.startTime !== "—")) : (info.endTime && info.endTime !== "—") || info.problemCount > 0) break;
    await sleep(500);
  }
  summary.timing.sourceReadyMs = elapsed();
  log("source", JSON.stringify(info));

  // 3. For a file: seek to (almost) the end so legends show the last values and following plots end there
  async function seekToEnd() {
    const box = await page.evaluate(() => {
      // the Scrubber: a 32px-high row in the playback bar (the one holding PlaybackTime-text)
      const t = document.querySelector('[data-testid="PlaybackTime-text"]');
      const is32 = (d) => d.style.height === "32px";
      let bar = t, cands = [];
      for (let i = 0; i < 10 && bar && cands.length === 0; i++) { bar = bar.parentElement; cands = bar ? [...bar.querySelectorAll("div")].filter(is32) : []; }
      const r = cands[0]?.getBoundingClientRect();
      return r ? { x: r.x, y: r.y, w: r.width, h: r.height } : undefined;
    });
    if (!box) return false;
    await page.mouse.click(box.x + box.w - 2, box.y + box.h / 2);
    await page.mouse.move(800, 500);
    return true;
  }
  if (args.mcap && info.endTime && info.endTime !== "—") summary.seekedToEnd = await seekToEnd();

  // 4. Poll panel state until stable
  const readPanels = async () => {
    const dom = await page.evaluate(({ ids, cfgTitles }) => ids.map((id) => {
      const el = document.querySelector(`[data-testid="panel-mouseenter-container ${id}"]`);
      const type = id.split("!")[0];
      if (!el) return { id, type, present: false };
      const r = el.getBoundingClientRect();
      const res = { id, type, present: true, title: el.querySelector("header > .MuiTypography-root")?.innerText.trim() || cfgTitles[id] || id, rect: { x: r.x, y: r.y, w: r.width, h: r.height } };
      const text = el.innerText;
      res.waitingText = /Waiting for|No data|Unknown topic|not found/i.test(text) ? (text.match(/[^\n]*(Waiting for|No data|Unknown topic|not found)[^\n]*/i) ?? [""])[0] : undefined;
      if (type === "Plot") {
        res.series = [...el.querySelectorAll('[class*="-plotName"]')].map((n) => {
          const row = n.parentElement;
          const checked = row.querySelector('input[type="checkbox"]')?.checked;
          return { label: n.innerText.trim(), value: row.querySelector('[class*="-plotValue"]')?.innerText.trim() ?? null, enabled: checked !== false };
        });
        const legend = el.querySelector('[class*="-rootFloating"], [class*="-container-ref"]');
        const lr = legend?.getBoundingClientRect();
        const hdr = el.querySelector("header")?.getBoundingClientRect();
        res.mask = [lr && { x: lr.x - r.x, y: lr.y - r.y, w: lr.width, h: lr.height }, hdr && { x: 0, y: 0, w: r.width, h: hdr.height + 2 }].filter(Boolean);
      } else if (type === "RosOut") {
        const rows = [...el.querySelectorAll("div[title]")].filter((d) => /^\[\s*(DEBUG|INFO|WARN|ERROR|FATAL)\]/.test(d.innerText.trim()));
        res.rows = rows.length;
        res.firstRows = rows.slice(0, 3).map((d) => d.innerText.replace(/\s+/g, " ").trim().slice(0, 160));
      } else {
        res.textSample = text.replace(/\s+/g, " ").slice(0, 200);
      }
      return res;
    }), { ids: panelIds, cfgTitles: Object.fromEntries(panelIds.map((id) => [id, layout.configById?.[id]?.title])) });
    // colored-pixel count of each plot canvas (legend and toolbar masked): series are drawn in saturated colors
    for (const p of dom) {
      if (p.type !== "Plot" || !p.present || p.rect.w < 10) continue;
      const png = await page.screenshot({ clip: { x: p.rect.x, y: p.rect.y, width: p.rect.w, height: p.rect.h }, timeout: 10000 });
      p.coloredPixels = await page.evaluate(async ({ b64, mask }) => {
        const bmp = await createImageBitmap(await (await fetch(`data:image/png;base64,${b64}`)).blob());
        const c = new OffscreenCanvas(bmp.width, bmp.height); const g = c.getContext("2d"); g.drawImage(bmp, 0, 0);
        const s = bmp.width / (mask.scaleW || bmp.width);
        g.fillStyle = "#fff"; for (const m of mask.rects) g.fillRect(m.x * s - 2, m.y * s - 2, m.w * s + 4, m.h * s + 4);
        const d = g.getImageData(0, 0, bmp.width, bmp.height).data; let n = 0;
        for (let i = 0; i < d.length; i += 4) { const mx = Math.max(d[i], d[i + 1], d[i + 2]), mn = Math.min(d[i], d[i + 1], d[i + 2]); if (mx - mn > 70) n++; }
        return n;
      }, { b64: png.toString("base64"), mask: { rects: p.mask, scaleW: p.rect.w } });
      delete p.mask;
    }
    for (const p of dom) {
      delete p.rect;
      if (!p.present) { p.status = "missing"; continue; }
      if (p.type === "Plot") {
        const enabled = p.series.filter((s) => s.enabled);
        const withVal = enabled.filter((s) => s.value != null && s.value !== "");
        p.seriesWithValue = `${withVal.length}/${enabled.length}`;
        // Values in the legend are not enough: a plot whose x axis misses its data (a message-path
        // axis under a following view width) lists the values and draws nothing.
        const drawn = p.coloredPixels === undefined || p.coloredPixels > 40;
        p.status = enabled.length > 0 && withVal.length === enabled.length && drawn ? "data"
          : withVal.length > 0 || p.coloredPixels > 40 ? "partial" : "empty";
      } else if (p.type === "RosOut") {
        p.status = p.rows > 0 ? "data" : "empty";
      } else {
        p.status = p.waitingText ? "empty" : "unknown";
      }
    }
    return dom;
  };

  let panels = await readPanels();
  let lastKey = "", stableSince = Date.now(), lastResortSeek = false;
  const settleMs = args.settle * 1000;
  while (remaining() > 12000) {
    const key = JSON.stringify(panels.map((p) => [p.status, p.rows, p.seriesWithValue, args.mcap && p.coloredPixels && Math.round(p.coloredPixels / 50)]));
    if (key !== lastKey) { lastKey = key; stableSince = Date.now(); log("panels", key); }
    const allData = panels.every((p) => p.status === "data" || p.status === "unknown");
    const stableFor = Date.now() - stableSince;
    if (allData && stableFor >= Math.min(settleMs, 3000)) break;
    if (!allData && stableFor >= settleMs * 2 && elapsed() > 20000) {
      // re-seek once in case the first click landed before the range was known
      if (args.mcap && !lastResortSeek) { lastResortSeek = true; info = await srcInfo(); if (info.endTime && info.endTime !== "—") { summary.seekedToEnd = await seekToEnd(); stableSince = Date.now(); } else break; }
      else break;
    }
    await sleep(1000);
    panels = await readPanels();
  }
  summary.timing.dataSettledMs = elapsed();
  info = await srcInfo();
  summary.dataSource = info;

  // 5. Problems: open the "Problems" tab of the data source sidebar and read its list
  let problems = [];
  const tab = page.getByRole("tab", { name: /^Problems/ });
  if (await tab.count()) {
    await tab.first().click({ timeout: 5000 }).catch(() => {});
    await sleep(300);
    problems = await page.evaluate(() => {
      const t = [...document.querySelectorAll('[role="tab"]')].find((x) => /^Problems/.test(x.innerText.trim()));
      let scope = t; while (scope && !scope.querySelector(".MuiListItemText-primary") && !/No problems found/.test(scope.innerText)) scope = scope.parentElement;
      if (!scope) return [];
      return [...scope.querySelectorAll(".MuiListItemButton-root")].map((b) => ({
        // MUI icons carry data-testid="<IconName>Icon": ErrorOutlineOutlined / Warning* / InfoOutlined
        severity: (([...b.querySelectorAll("svg[data-testid]")].map((x) => x.getAttribute("data-testid")).join(" ").match(/Error|Warn|Info/) ?? ["?"])[0]).replace("Error", "error").replace("Warn", "warn").replace("Info", "info"),
        icon: [...b.querySelectorAll("svg[data-testid]")].map((x) => x.getAttribute("data-testid")).join(" ") || undefined,
        message: b.innerText.trim(),
      }));
    });
    summary.problemsSource = "Problems tab (data source sidebar)";
  } else {
    summary.problemsSource = "console 'Player problem' logs only (Problems tab not found)";
  }
  if (problems.length === 0 && Object.keys(playerProblemLogs).length > 0 && !(await tab.count())) {
    problems = Object.entries(playerProblemLogs).map(([id, t]) => ({ severity: (/severity: (\w+)/.exec(t) ?? [])[1] ?? "?", message: (/message: ([^,]*)/.exec(t) ?? [])[1] ?? t }));
  }
  summary.problems = problems;
  summary.playerProblemIds = Object.keys(playerProblemLogs);

  // 6. Screenshot (problems tab open, mouse parked)
  if (args.screenshot) {
    await page.mouse.move(5, 995);
    await page.screenshot({ path: args.screenshot, timeout: 15000 });
    summary.screenshot = path.resolve(args.screenshot);
  }

  summary.panels = panels;
  summary.consoleErrors = consoleErrors;

  // 7. Verdict
  for (const p of panels) {
    if (p.status === "data" || p.status === "unknown") continue;
    if (p.status === "partial" && args.allowPartial) continue;
    const detail = p.type === "Plot" ? ` (series with a value: ${p.seriesWithValue}; ${p.series.filter((s) => s.enabled && !s.value).map((s) => s.label).join(", ") || "-"} empty; colored px ${p.coloredPixels})` : p.type === "RosOut" ? ` (rows ${p.rows})` : "";
    summary.failures.push(`panel ${p.id} "${p.title ?? ""}": ${p.status}${detail}`);
  }
  const allPanelsData = panels.every((p) => p.status === "data" || p.status === "unknown");
  for (const pr of problems) {
    // A replay that ended before the check did (its info status, then "Connection failed" once
    // the socket closes) is a note, not a failure, when every panel had data; any other problem,
    // of any severity, fails.
    if (args.ws && allPanelsData && /^Connection failed$|the replay has ended/.test(pr.message)) { summary.notes = [...(summary.notes ?? []), `the server ended the stream before the check did: ${pr.message}`]; continue; }
    summary.failures.push(`problem [${pr.severity}] ${pr.message}`);
  }
  summary.ok = summary.failures.length === 0;
} catch (e) {
  summary.failures.push(`harness: ${String(e.message ?? e).split("\n")[0]}`);
  summary.consoleErrors = consoleErrors;
  summary.harnessError = true;
}
summary.timing = { ...(summary.timing ?? {}), totalMs: elapsed() };
await cleanup();
clearTimeout(hardTimer);
console.log(JSON.stringify(summary, null, 2));
process.exit(summary.harnessError ? 2 : summary.ok ? 0 : 1);
