"""W8: the design explorer's latency, measured in a real browser.

Starts the explorer on the seed design (127.0.0.1, a free port), opens it in Debian's
headless chromium (/usr/bin/chromium through /usr/bin/chromedriver, Selenium; nothing is
downloaded), and makes N changes of the main-lens aperture D, each to a value not shown
before (15.0, 15.1, ... mm: nothing can come from a cache), 0.3 s apart (a person's pause;
the sample map and microlens images of the previous change finish in it).
For each, the time from the Enter key (the commit of the control, a keydown listener in
the page, on the page's clock) to the moment both the blur figure and the samples figure
show the new design (the page's "status" data source, updated in the same document patch
as the figures' data), polled every animation frame in the page. The issue's target: median
<= 150 ms, 95th percentile <= 400 ms on the 2-core machine.

    python benches/w8_explore.py            # 50 changes
    python benches/w8_explore.py --quick    # 5 changes (smoke test)

Self-contained (needs the `explore` and `test` extras and chromium). Prints one JSON
document.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

import numpy as np

import splitlf
from splitlf.explorer import serve

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"

DEEP = """
function deep(root, sel) {
  let out = [...root.querySelectorAll(sel)];
  for (const el of root.querySelectorAll('*'))
    if (el.shadowRoot) out = out.concat(deep(el.shadowRoot, sel));
  return out;
}
"""

STATUS = ("const doc = window.Bokeh && Bokeh.documents[0];"
          "const s = doc && doc.get_model_by_name('status');")

#: Arms the timer: the next Enter keydown (anywhere; key events leave shadow roots)
#: stamps window.__t0.
ARM = """
window.__t0 = null;
document.addEventListener('keydown', e => { if (e.key === 'Enter' && window.__t0 === null)
  window.__t0 = performance.now(); }, {capture: true, once: true});
"""

#: Resolves with ms from the Enter to the first frame where both views show a design
#: newer than arguments[0].
WAIT = """
const before = arguments[0], done = arguments[arguments.length - 1];
const status = Bokeh.documents[0].get_model_by_name('status');
function tick() {
  const s = {blur: status.data.blur[0], samples: status.data.samples[0]};
  if (window.__t0 !== null && s.blur > before && s.samples === s.blur)
    return done(performance.now() - window.__t0);
  requestAnimationFrame(tick);
}
tick();
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="5 changes (smoke test)")
    ap.add_argument("--changes", type=int, default=50)
    args = ap.parse_args()
    n = 5 if args.quick else args.changes

    os.environ.setdefault("SE_OFFLINE", "true")
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.keys import Keys

    srv = serve(splitlf.Design.preset("seed"), threaded=True)
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for a in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
              "--window-size=1600,1300", "--disable-gpu"):
        opts.add_argument(a)
    d = webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)
    d.set_script_timeout(30)
    try:
        d.get(srv.url)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            s = d.execute_script(STATUS + "return s ? s.data.samples[0] : 0;")
            if s >= 1:
                break
            time.sleep(0.1)
        time.sleep(1.0)
        field = d.execute_script(DEEP + "return deep(document, 'input[placeholder=\"D\"]')[0];")
        values = [f"{15.0 + 0.1 * i:.1f}" for i in range(n)]
        ms = []
        for i in range(n):
            time.sleep(0.3)
            before = d.execute_script(STATUS + "return s.data.blur[0];")
            field.send_keys(Keys.END + Keys.BACKSPACE * 10 + values[i])
            d.execute_script(ARM)
            field.send_keys(Keys.ENTER)
            ms.append(float(d.execute_async_script(WAIT, before)))
    finally:
        d.quit()
        srv.stop()
    a = np.array(ms)
    print(json.dumps({
        "workload": "W8 explorer: control change -> blur and samples figures updated",
        "design": "seed", "changes": n,
        "median_ms": round(float(np.median(a)), 1),
        "p95_ms": round(float(np.percentile(a, 95)), 1),
        "min_ms": round(float(a.min()), 1), "max_ms": round(float(a.max()), 1),
        "cpus": os.cpu_count(), "load_average_1min": round(os.getloadavg()[0], 2),
        "python": platform.python_version(),
    }, indent=2))


if __name__ == "__main__":
    main()
