// Tiny static server with HTTP Range support (needed by Studio's remote-file MCAP reader).
import http from "node:http";
import fs from "node:fs";
import path from "node:path";
import { fileURLToPath } from "node:url";

const HERE = path.dirname(fileURLToPath(import.meta.url));
const TYPES = { ".html": "text/html; charset=utf-8", ".js": "text/javascript; charset=utf-8", ".json": "application/json",
  ".wasm": "application/wasm", ".png": "image/png", ".ttf": "font/ttf", ".mcap": "application/octet-stream", ".map": "application/json" };

/** routes: { "/index.html": absPath, ... } plus prefix mounts { "/studio/": dir } */
export function startServer({ files = {}, mounts = {}, log = () => {} } = {}) {
  const server = http.createServer((req, res) => {
    const url = new URL(req.url, "http://x");
    let p = decodeURIComponent(url.pathname);
    if (p === "/") p = "/index.html";
    if (p === "/favicon.ico") { res.writeHead(204); return res.end(); }
    let abs = files[p];
    if (!abs) {
      for (const [prefix, dir] of Object.entries(mounts)) {
        if (p.startsWith(prefix)) {
          const cand = path.resolve(dir, "." + p.slice(prefix.length - 1));
          if (cand.startsWith(path.resolve(dir))) abs = cand;
        }
      }
    }
    const cors = { "Access-Control-Allow-Origin": "*", "Access-Control-Allow-Headers": "*", "Access-Control-Expose-Headers": "Content-Length, Content-Range, Accept-Ranges, ETag" };
    if (req.method === "OPTIONS") { res.writeHead(204, cors); return res.end(); }
    let st;
    try { st = abs && fs.statSync(abs); } catch { st = undefined; }
    if (!st || !st.isFile()) { log(`404 ${p}`); res.writeHead(404, cors); return res.end("not found"); }
    const type = TYPES[path.extname(abs)] ?? "application/octet-stream";
    const base = { ...cors, "Content-Type": type, "Accept-Ranges": "bytes", "Cache-Control": "no-store",
      "ETag": `"${st.size}-${st.mtimeMs}"`, "Last-Modified": st.mtime.toUTCString() };
    const range = req.headers.range && /^bytes=(\d*)-(\d*)$/.exec(req.headers.range);
    if (range) {
      let start = range[1] === "" ? st.size - Number(range[2]) : Number(range[1]);
      let end = range[1] === "" || range[2] === "" ? st.size - 1 : Math.min(Number(range[2]), st.size - 1);
      if (start > end || start >= st.size) { res.writeHead(416, { ...base, "Content-Range": `bytes */${st.size}` }); return res.end(); }
      res.writeHead(206, { ...base, "Content-Range": `bytes ${start}-${end}/${st.size}`, "Content-Length": end - start + 1 });
      if (req.method === "HEAD") return res.end();
      return fs.createReadStream(abs, { start, end }).pipe(res);
    }
    res.writeHead(200, { ...base, "Content-Length": st.size });
    if (req.method === "HEAD") return res.end();
    fs.createReadStream(abs).pipe(res);
  });
  return new Promise((resolve) => server.listen(0, "127.0.0.1", () => resolve({ server, port: server.address().port })));
}
