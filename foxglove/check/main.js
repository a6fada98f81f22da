// Mounts @foxglove/studio-base 1.48.0's <App> the way packages/studio-web does,
// with an in-memory layout storage pre-loaded with the layout served at /layout.json
// and an in-memory app configuration. No build step: plain globals.
/* global React, ReactDOM */
(async function main() {
  const S = self; // the UMD bundle copied its exports onto self
  window.__studio = { stage: "starting", errors: [] };
  try {
    const layoutData = await (await fetch("/layout.json")).json();
    const LAYOUT_ID = new URL(location.href).searchParams.get("layoutId") || "harness-layout";
    const now = new Date().toISOString();

    // ---- in-memory ILayoutStorage (namespaced map) ----
    class MemoryLayoutStorage {
      constructor() { this.ns = new Map(); }
      _m(ns) { if (!this.ns.has(ns)) this.ns.set(ns, new Map()); return this.ns.get(ns); }
      async list(ns) {
        if (ns === "local" && !this._m(ns).has(LAYOUT_ID)) this._seed(ns);
        return [...this._m(ns).values()];
      }
      _seed(ns) {
        this._m(ns).set(LAYOUT_ID, S.migrateLayout({
          id: LAYOUT_ID, name: "harness: " + LAYOUT_ID, permission: "CREATOR_WRITE",
          baseline: { data: layoutData, savedAt: now }, working: undefined, syncInfo: undefined,
        }));
      }
      async get(ns, id) { await this.list(ns); return this._m(ns).get(id); }
      async put(ns, layout) { this._m(ns).set(layout.id, layout); return layout; }
      async delete(ns, id) { this._m(ns).delete(id); }
      async migrateUnnamespacedLayouts(_ns) {}
      async importLayouts({ fromNamespace, toNamespace }) {
        for (const l of await this.list(fromNamespace)) this._m(toNamespace).set(l.id, l);
      }
    }

    // ---- in-memory IAppConfiguration ----
    class MemoryAppConfiguration {
      constructor(init) { this.v = new Map(Object.entries(init)); this.l = new Map(); }
      get(k) { return this.v.get(k); }
      async set(k, val) { this.v.set(k, val); for (const cb of this.l.get(k) ?? []) cb(val); }
      addChangeListener(k, cb) { if (!this.l.has(k)) this.l.set(k, new Set()); this.l.get(k).add(cb); }
      removeChangeListener(k, cb) { this.l.get(k)?.delete(cb); }
    }
    const A = S.AppSetting;
    const appConfiguration = new MemoryAppConfiguration({
      [A.TELEMETRY_ENABLED]: false,
      [A.CRASH_REPORTING_ENABLED]: false,
      [A.HIDE_SIGN_IN_PROMPT]: true,
      [A.SHOW_OPEN_DIALOG_ON_STARTUP]: false,
      [A.UPDATES_ENABLED]: false,
      [A.COLOR_SCHEME]: "light",
      [A.LANGUAGE]: "en",
    });

    S.setReportErrorHandler((err, type) => {
      window.__studio.errors.push(`[reportError ${type}] ${err && err.stack ? err.stack : String(err)}`);
    });
    S.installDevtoolsFormatters();
    S.overwriteFetch();
    window.__studio.stage = "fonts";
    await S.waitForFonts();
    window.__studio.stage = "i18n";
    await S.initI18n();

    const dataSources = [
      new S.FoxgloveWebSocketDataSourceFactory(),
      new S.McapLocalDataSourceFactory(),
      new S.RemoteDataSourceFactory(),
    ];
    const root = ReactDOM.createRoot(document.getElementById("root"));
    root.render(React.createElement(S.App, {
      deepLinks: [window.location.href],
      dataSources,
      appConfiguration,
      layoutStorage: new MemoryLayoutStorage(),
      extensionLoaders: [],
      enableGlobalCss: true,
    }));
    window.__studio.stage = "mounted";
  } catch (err) {
    window.__studio.stage = "failed";
    window.__studio.errors.push(String(err && err.stack ? err.stack : err));
    console.error("mounting Studio failed", err);
  }
})();
