// Real-client test of `unilod export --3dtiles` (issue 20, item 2): CesiumJS (npm `cesium`) in
// Debian's headless Chromium with software WebGL (SwiftShader) loads the tileset from a server on
// 127.0.0.1, looks at it from near and from far, and checks what it drew:
// - near: every selected tile loaded without a failure, model pixels cover a good part of the
//   view and river pixels are blue (the unlit river material);
// - far: the numbers of tiles Cesium selects for rendering and keeps loaded (after
//   trimLoadedTiles: no cache beyond the view) fall: the coarse levels replace the fine ones, geometricError drives the selection.
// Usage: node run.mjs --tileset DIR [--out PNG_PREFIX] [--chromium PATH]
// Exit: 0 pass, 1 fail, 77 skip (Chromium cannot start: the message says why).
import { chromium } from "playwright-core";
import http from "node:http";
import fs from "node:fs";
import path from "node:path";
import { fileURLToPath } from "node:url";

const here = path.dirname(fileURLToPath(import.meta.url));
const args = process.argv.slice(2);
const opt = (name, fallback) => {
    const i = args.indexOf(name);
    return i >= 0 && i + 1 < args.length ? args[i + 1] : fallback;
};
const tilesetDir = opt("--tileset");
const outPrefix = opt("--out");
const chromiumPath = opt("--chromium", "/usr/bin/chromium");
if (!tilesetDir || !fs.existsSync(path.join(tilesetDir, "tileset.json"))) {
    console.error(`run.mjs: --tileset DIR with a tileset.json is required (got '${tilesetDir}')`);
    process.exit(1);
}
const cesiumDir = path.join(here, "node_modules", "cesium", "Build", "Cesium");
if (!fs.existsSync(path.join(cesiumDir, "Cesium.js"))) {
    console.error(`run.mjs: ${cesiumDir}/Cesium.js is missing: run 'npm ci' in ${here}`);
    process.exit(1);
}

const types = { ".js": "text/javascript", ".json": "application/json", ".html": "text/html",
    ".css": "text/css", ".glb": "model/gltf-binary", ".png": "image/png", ".wasm": "application/wasm" };
const requests = { tiles: 0, failed: [] };
const server = http.createServer((req, res) => {
    const url = decodeURIComponent(new URL(req.url, "http://127.0.0.1").pathname);
    let file = null;
    if (url === "/" || url === "/index.html") file = path.join(here, "page.html");
    else if (url.startsWith("/cesium/")) file = path.join(cesiumDir, url.slice(8));
    else if (url.startsWith("/tileset/")) {
        file = path.join(tilesetDir, url.slice(9));
        if (url.endsWith(".glb")) requests.tiles += 1;
    }
    const root = url.startsWith("/tileset/") ? path.resolve(tilesetDir) : here;
    if (!file || !path.resolve(file).startsWith(root) || !fs.existsSync(file) ||
        !fs.statSync(file).isFile()) {
        requests.failed.push(url);
        res.writeHead(404);
        res.end();
        return;
    }
    res.writeHead(200, { "Content-Type": types[path.extname(file)] || "application/octet-stream" });
    fs.createReadStream(file).pipe(res);
});
await new Promise((r) => server.listen(0, "127.0.0.1", r));
const port = server.address().port;

let browser;
try {
    browser = await chromium.launch({
        executablePath: chromiumPath,
        headless: true,
        args: ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
            "--ignore-gpu-blocklist", "--disable-background-networking",
            "--disable-component-update", "--disable-sync", "--no-first-run", "--disable-quic"],
    });
} catch (e) {
    console.log(`SKIP: Chromium (${chromiumPath}) cannot start: ${String(e.message).split("\n")[0]}`);
    server.close();
    process.exit(77);
}

let failures = 0;
const check = (ok, what) => {
    console.log(`${ok ? "ok  " : "FAIL"} ${what}`);
    if (!ok) failures += 1;
};
try {
    const page = await browser.newPage({ viewport: { width: 960, height: 540 } });
    const consoleErrors = [];
    page.on("console", (m) => { if (m.type() === "error") consoleErrors.push(m.text()); });
    page.on("pageerror", (e) => consoleErrors.push(String(e)));
    await page.goto(`http://127.0.0.1:${port}/index.html`);
    await page.waitForFunction(() => window.unilod !== undefined, null, { timeout: 60000 });
    const webgl = await page.evaluate(() => {
        const c = document.createElement("canvas");
        return !!(c.getContext("webgl2") || c.getContext("webgl"));
    });
    if (!webgl) {
        console.log("SKIP: Chromium started but has no WebGL (no SwiftShader)");
        await browser.close();
        server.close();
        process.exit(77);
    }
    const info = await page.evaluate(() => window.unilod.load(2));
    console.log(`tileset: bounding radius ${info.radius.toFixed(0)} m at longitude ` +
        `${(info.centre.longitude * 180 / Math.PI).toFixed(4)}, latitude ` +
        `${(info.centre.latitude * 180 / Math.PI).toFixed(4)}, height ${info.centre.height.toFixed(0)} m`);

    const views = [
        { name: "near", range: 0.3 * info.radius, pitch: -35 },
        { name: "far", range: 40 * info.radius, pitch: -60 },
    ];
    const results = {};
    for (const v of views) {
        await page.evaluate(({ range, pitch }) => window.unilod.look(range, pitch), v);
        const settled = await page.evaluate((t) => window.unilod.settle(t), 240000);
        const px = await page.evaluate(() => window.unilod.pixels());
        const { selected, loaded } = await page.evaluate(
            () => ({ selected: window.unilod.selected, loaded: window.unilod.loaded }));
        results[v.name] = { settled, selected, loaded, ...px };
        console.log(`${v.name}: range ${v.range.toFixed(0)} m, settled ${settled}, ${selected} ` +
            `tiles selected, ${loaded} loaded, ${px.model} model pixels, ${px.blue} blue of ` +
            `${px.width}x${px.height}`);
        if (outPrefix) await page.screenshot({ path: `${outPrefix}_${v.name}.png` });
    }
    const errors = await page.evaluate(() => window.unilod.errors);
    check(results.near.settled && results.far.settled, "every selected tile loaded (tilesLoaded)");
    check(errors.length === 0, `no tile failed to load (${errors.join("; ")})`);
    check(requests.failed.length === 0, `no request failed (${requests.failed.join(", ")})`);
    check(requests.tiles > 0, `the client fetched tile content (${requests.tiles} .glb requests)`);
    const n = results.near;
    check(n.model > 0.3 * n.width * n.height,
        `near: terrain-grey pixels cover the view (${n.model} of ${n.width * n.height} pixels)`);
    check(n.blue > 200, `near: rivers drawn blue (${n.blue} pixels)`);
    check(results.far.selected >= 1 && results.far.selected < n.selected,
        `far: fewer tiles selected than near (${results.far.selected} < ${n.selected})`);
    check(results.far.loaded >= 1 && results.far.loaded < n.loaded,
        `far: fewer tiles loaded than near (${results.far.loaded} < ${n.loaded})`);
    check(results.far.model > 0 && results.far.model < n.model,
        `far: the model is smaller on screen (${results.far.model} pixels)`);
    const bad = consoleErrors.filter((t) => !/favicon/.test(t));
    check(bad.length === 0, `no errors in the browser console (${bad.slice(0, 3).join(" | ")})`);
} finally {
    await browser.close();
    server.close();
}
process.exit(failures === 0 ? 0 : 1);
