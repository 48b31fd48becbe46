// The report in a real browser (ctest report.browser, run by run_report_browser_test.sh): opens
// a simulate-part report.html from file:// in Debian's chromium (headless, software WebGL) through
// playwright-core, and fails when
//  - the page logs a console error, throws, or a request fails or leaves the machine (the result
//    folder must work offline: every request must be a file in it);
//  - the 3-D view does not come up, or its canvas is blank (too few pixels differ from the
//    background) or looks unlike the committed baseline (block colours, loosely);
//  - a click on the deepest mark's point (after its "3-D" link in the marks table centred the
//    view on it) does not read that mark's depth, number and program line from report.json;
//  - the page's text holds an absolute path or a code identifier;
//  - the page is wider than a 1280 px window (a horizontal scroll bar), states no verdict (when
//    report.json has one), or its marks table is not the deepest marks of report.json, each no
//    smaller than a speck, at most 25 of them, the rest counted in marks.csv;
//  - the listed marks are not drawn in the 3-D view (a numbered label per mark of the view shown,
//    the deepest mark outlined and its label on the canvas once its "3-D" link centred it);
//  - two mark numbers of the 3-D view overlap or one covers another's point: as drawn (the whole
//    view, then zoomed far out so that the points crowd), and as placed by the view's placement
//    on made-up crowds (30 numbers at one point, 40 in a small area, random crowds).
// Screenshots (SHOTS_FOLDER): the top of the page, the marks table, the 3-D view.
// Usage: node report_browser_test.cjs RESULT_FOLDER BASELINE.json SHOTS_FOLDER [--update-baseline | --no-baseline]
// --no-baseline: for a report other than the baseline's (the mould sample, by hand).
// Environment: VMSIM_WEB_MODULES (viz/web/node_modules), VMSIM_CHROMIUM (default /usr/bin/chromium).
'use strict';
const fs = require('fs');
const path = require('path');
const { pathToFileURL } = require('url');

const [folder, baselinePath, shotsFolder] = process.argv.slice(2);
const updateBaseline = process.argv.includes('--update-baseline');
const noBaseline = process.argv.includes('--no-baseline');
if (!folder || !baselinePath || !shotsFolder) {
  console.error('usage: node report_browser_test.cjs RESULT_FOLDER BASELINE.json SHOTS_FOLDER [--update-baseline]');
  process.exit(2);
}
const modules = process.env.VMSIM_WEB_MODULES;
const { chromium } = require(path.join(modules, 'playwright-core'));
const executablePath = process.env.VMSIM_CHROMIUM || '/usr/bin/chromium';

const failures = [];
function check(ok, message) {
  console.log((ok ? 'ok    ' : 'FAILED ') + message);
  if (!ok) failures.push(message);
}

// Block means of a PNG (RGB, 0..1) and the share of pixels that are not the white background,
// computed in the page from the screenshot (no image library needed here).
async function imageStatistics(page, png, blocksX, blocksY) {
  return page.evaluate(async ({ base64, blocksX, blocksY }) => {
    const image = new Image();
    image.src = 'data:image/png;base64,' + base64;
    await image.decode();
    const canvas = document.createElement('canvas');
    canvas.width = image.width;
    canvas.height = image.height;
    const context = canvas.getContext('2d');
    context.drawImage(image, 0, 0);
    const pixels = context.getImageData(0, 0, image.width, image.height).data;
    const sums = new Float64Array(blocksX * blocksY * 3), counts = new Float64Array(blocksX * blocksY);
    let foreground = 0, blue = 0, red = 0;
    for (let y = 0; y < image.height; ++y) {
      for (let x = 0; x < image.width; ++x) {
        const k = 4 * (x + image.width * y);
        const [r, g, b] = [pixels[k], pixels[k + 1], pixels[k + 2]];
        if (Math.max(255 - r, 255 - g, 255 - b) > 24) ++foreground;
        if (b > r + 40 && b > g) ++blue;
        if (r > b + 40 && r > g + 40) ++red;
        const block = Math.floor((x * blocksX) / image.width) + blocksX * Math.floor((y * blocksY) / image.height);
        sums[3 * block] += r / 255;
        sums[3 * block + 1] += g / 255;
        sums[3 * block + 2] += b / 255;
        counts[block] += 1;
      }
    }
    const total = image.width * image.height;
    return {
      width: image.width, height: image.height,
      foreground: foreground / total, blue: blue / total, red: red / total,
      blocks: Array.from(sums, (s, i) => Math.round((1000 * s) / counts[Math.floor(i / 3)]) / 1000),
    };
  }, { base64: png.toString('base64'), blocksX, blocksY });
}

(async () => {
  const report = JSON.parse(fs.readFileSync(path.join(folder, 'report.json'), 'utf8'));
  fs.mkdirSync(shotsFolder, { recursive: true });
  const started = Date.now();
  const browser = await chromium.launch({
    executablePath,
    headless: true,
    args: ['--no-sandbox', '--disable-gpu', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
           '--disable-background-networking', '--disable-component-update', '--disable-sync',
           '--no-first-run', '--disable-default-apps', '--mute-audio'],
  });
  const context = await browser.newContext({ viewport: { width: 1280, height: 1000 }, deviceScaleFactor: 1 });
  const page = await context.newPage();
  const problems = [];
  page.on('console', (message) => {
    if (message.type() === 'error') problems.push('console error: ' + message.text());
  });
  page.on('pageerror', (error) => problems.push('page error: ' + error.message));
  page.on('requestfailed', (request) => problems.push('request failed: ' + request.url() + ' ' +
                                                      (request.failure() ? request.failure().errorText : '')));
  // Nothing may leave the machine: every request must be a file of the result folder.
  await context.route((url) => !/^(file|data|blob):/.test(url.href), (route) => {
    problems.push('network request: ' + route.request().url());
    return route.abort();
  });
  const url = pathToFileURL(path.join(folder, 'report.html')).href;
  const opened = Date.now();
  await page.goto(url, { waitUntil: 'load' });
  await page.waitForFunction(() => window.vmsimView3d && (window.vmsimView3d.ready || window.vmsimView3d.error),
                             null, { timeout: 60000 }).catch(() => {});
  const view = await page.evaluate(() => window.vmsimView3d ? {
    ready: window.vmsimView3d.ready, error: window.vmsimView3d.error,
    vertices: window.vmsimView3d.vertices, triangles: window.vmsimView3d.triangles,
    timings: window.vmsimView3d.timings_ms,
    scriptsLoaded: performance.getEntriesByType('navigation')[0].domContentLoadedEventEnd } : null);
  // Two frames for the first render to reach the canvas.
  await page.evaluate(() => new Promise((done) => requestAnimationFrame(() => requestAnimationFrame(done))));
  const loadedMs = Date.now() - started, pageMs = Date.now() - opened;
  check(view && view.ready && !view.error, '3-D view came up' + (view && view.error ? ': ' + view.error : ''));
  check(view && view.triangles > 1000, '3-D view has a surface (' + (view ? view.triangles : 0) + ' triangles, ' +
        (view ? view.vertices : 0) + ' vertices)');

  // A page to forward: as wide as the window at most (no horizontal scroll at 1280 px).
  const widths = await page.evaluate(() => ({ scroll: document.documentElement.scrollWidth,
                                              client: document.documentElement.clientWidth }));
  check(widths.scroll <= widths.client, 'the page fits a 1280 px window (scroll width ' + widths.scroll +
        ' px, window ' + widths.client + ' px)');
  await page.screenshot({ path: path.join(shotsFolder, 'report_top.png'), fullPage: false });
  // The verdict, as report.json states it.
  if (report.verdict) {
    const headline = await page.evaluate(() => {
      const h = document.querySelector('.verdict h2');
      return h ? h.innerText : '';
    });
    check(headline.length > 0 && headline === report.verdict.headline, 'the page states the verdict: "' + headline + '"');
  }
  // The marks table: the deepest marks of report.json, in order, none smaller than a speck, at
  // most 25; marks.csv holds every mark and speck.
  const listed = await page.evaluate(() => Array.from(document.querySelectorAll('table.marks tr'))
    .slice(1).map((row) => Number(row.cells[0].innerText.split(/\s/)[0])));
  const allMarks = report.marks || [];
  const expectedRows = Math.min(25, allMarks.length);
  check(listed.length === expectedRows && listed.every((rank, k) => rank === allMarks[k].rank),
        'the marks table lists report.json\'s ' + expectedRows + ' deepest marks in order (' + listed.length + ' rows)');
  const minArea = report.specks ? report.specks.min_area_mm2 : 0;
  check(allMarks.slice(0, expectedRows).every((m, k) => m.area_mm2 >= minArea &&
        (k === 0 || m.depth_um <= allMarks[k - 1].depth_um)),
        'listed marks are deepest first and none is smaller than a speck (' + (minArea || 0).toFixed(3) + ' mm2)');
  const csvRows = fs.readFileSync(path.join(folder, 'marks.csv'), 'utf8').split('\n').filter((l) => l.length).length - 1;
  const specks = report.specks ? report.specks.count : 0;
  check(csvRows === allMarks.length + specks, 'marks.csv has every mark and speck (' + csvRows + ' rows = ' +
        allMarks.length + ' marks + ' + specks + ' specks)');
  console.log('marks: ' + allMarks.length + ' marks, ' + specks + ' specks, ' + listed.length + ' listed in the page');
  if (listed.length) {
    await page.locator('table.marks').scrollIntoViewIfNeeded();
    await page.evaluate(() => document.querySelector('table.marks').scrollIntoView());
    await page.screenshot({ path: path.join(shotsFolder, 'report_marks_table.png'), fullPage: false });
  }
  // The listed marks of the first surface view are labelled in the 3-D view.
  if (view && view.ready) {
    const overlay = await page.evaluate(() => ({
      labels: window.vmsimView3d.markLabels, view: window.vmsimView3d.view,
      elements: document.querySelectorAll('#view3d .view3d-mark-label').length }));
    const wanted = allMarks.filter((m) => listed.includes(m.rank) && m.view === overlay.view).length;
    check(overlay.labels === wanted && overlay.elements === wanted,
          'the 3-D view labels the ' + wanted + ' listed marks of its ' + overlay.view + ' view (' + overlay.elements + ' labels)');
  }

  // Mark numbers never overlap: the placement on made-up crowds, checked here apart from it.
  if (view && view.ready) {
    const crowds = await page.evaluate(() => {
      const place = window.vmsimView3d.placeLabels;
      let seed = 12345;
      const random = () => ((seed = (seed * 1103515245 + 12345) % 2147483648) / 2147483648);
      const cases = [];
      const area = { x0: 0, y0: 0, x1: 900, y1: 540 };
      cases.push({ name: '30 at one point', area, requests: Array.from({ length: 30 }, (_, k) => ({ x: 400, y: 300, width: 14 + 8 * (k >= 9), height: 18 })) });
      cases.push({ name: '40 in 120 x 60 px', area, requests: Array.from({ length: 40 }, () => ({ x: 400 + 120 * random(), y: 250 + 60 * random(), width: 22, height: 18 })) });
      for (let c = 0; c < 20; ++c) {
        cases.push({ name: 'random crowd ' + c, area, requests: Array.from({ length: 25 }, () => ({
          x: 450 + 200 * (random() - 0.5), y: 270 + 150 * (random() - 0.5), width: 14 + 8 * (random() < 0.5), height: 18 })) });
      }
      return cases.map((c) => ({ name: c.name, requests: c.requests, area: c.area, boxes: place(c.requests, c.area) }));
    });
    const problemsOf = (requests, boxes, area) => {
      const found = [];
      boxes.forEach((a, i) => {
        if (!a) return;
        if (Math.abs(a.x1 - a.x0 - requests[i].width) > 1e-6 || Math.abs(a.y1 - a.y0 - requests[i].height) > 1e-6) found.push('box ' + i + ' resized');
        if (area && (a.x0 < area.x0 || a.y0 < area.y0 || a.x1 > area.x1 || a.y1 > area.y1)) found.push('box ' + i + ' outside');
        boxes.forEach((b, j) => {
          if (j <= i || !b) return;
          if (a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1) found.push('boxes ' + i + ' and ' + j + ' overlap');
        });
        requests.forEach((r, j) => {
          if (j !== i && r.x > a.x0 && r.x < a.x1 && r.y > a.y0 && r.y < a.y1) found.push('box ' + i + ' covers point ' + j);
        });
      });
      return found;
    };
    for (const c of crowds) {
      const placedCount = c.boxes.filter(Boolean).length;
      const found = problemsOf(c.requests, c.boxes, c.area);
      if (c.name.startsWith('random') && found.length === 0 && placedCount > 0) continue;  // one line for all below
      check(found.length === 0 && placedCount >= Math.min(10, c.requests.length),
            '3-D view\'s number placement, ' + c.name + ': ' + placedCount + ' placed, none overlapping' +
            (found.length ? ': ' + found.slice(0, 3).join(', ') : ''));
    }
    const randomOk = crowds.filter((c) => c.name.startsWith('random')).every((c) => problemsOf(c.requests, c.boxes, c.area).length === 0);
    check(randomOk, "3-D view's number placement, 20 random crowds of 25: none overlapping");
    // As drawn: the whole view, then zoomed out until the marks' points crowd together.
    const drawn = async () => page.evaluate(() => Array.from(document.querySelectorAll('#view3d .view3d-mark-label'))
      .filter((label) => label.style.display !== 'none')
      .map((label) => { const r = label.getBoundingClientRect(); return { rank: label.dataset.rank, x0: r.left, y0: r.top, x1: r.right, y1: r.bottom,
                                                                          anchor: label.vmsimAnchor }; }));
    for (const [name, factor] of [['the whole view', 1], ['zoomed far out', 0.08]]) {
      if (factor !== 1) {
        await page.evaluate((f) => window.vmsimView3d.zoom(f), factor);
        await page.evaluate(() => new Promise((done) => requestAnimationFrame(() => requestAnimationFrame(done))));
      }
      const boxes = await drawn();
      const box = await page.locator('#view3d').boundingBox();
      const requests = boxes.map((b) => ({ x: box.x + b.anchor[0], y: box.y + b.anchor[1], width: b.x1 - b.x0, height: b.y1 - b.y0 }));
      const found = problemsOf(requests, boxes, null);
      check(found.length === 0, 'the 3-D view\'s mark numbers, ' + name + ': ' + boxes.length + ' shown, none over another or its point' +
            (found.length ? ': ' + found.slice(0, 3).join(', ') : ''));
      if (factor !== 1) await page.locator('#view3d').screenshot({ path: path.join(shotsFolder, 'view3d_crowded_numbers.png') });
    }
    await page.locator('#view3d-reset').click();
  }

  // The page at its 3-D section, and the view alone, against the baseline.
  await page.locator('#view-3d').scrollIntoViewIfNeeded();
  await page.evaluate(() => document.getElementById('view-3d').scrollIntoView());
  await page.screenshot({ path: path.join(shotsFolder, 'report_view3d_section.png'), fullPage: false });
  const viewShot = await page.locator('#view3d').screenshot({ path: path.join(shotsFolder, 'view3d.png') });
  const statistics = await imageStatistics(page, viewShot, 16, 8);
  console.log('view statistics: foreground ' + statistics.foreground.toFixed(3) + ', blue ' + statistics.blue.toFixed(4) +
              ', red ' + statistics.red.toFixed(4));
  check(statistics.foreground > 0.05, 'the 3-D view is not blank (' + (100 * statistics.foreground).toFixed(1) +
        ' % of its pixels are not background; at least 5 %)');
  if (noBaseline) {
    console.log('no baseline comparison (--no-baseline)');
  } else if (updateBaseline) {
    fs.writeFileSync(baselinePath, JSON.stringify(statistics, null, 1) + '\n');
    console.log('baseline written: ' + baselinePath);
  } else {
    const baseline = JSON.parse(fs.readFileSync(baselinePath, 'utf8'));
    let difference = 0;
    for (let i = 0; i < baseline.blocks.length; ++i) difference += Math.abs(baseline.blocks[i] - statistics.blocks[i]);
    difference /= baseline.blocks.length;
    check(difference < 0.06, 'the 3-D view looks like the baseline (mean block colour difference ' +
          difference.toFixed(4) + ', at most 0.06)');
    check(Math.abs(statistics.foreground - baseline.foreground) < 0.25 * baseline.foreground,
          'as much of the view is surface as in the baseline (' + statistics.foreground.toFixed(3) + ' against ' +
          baseline.foreground.toFixed(3) + ')');
  }

  // The deepest mark: its "3-D" link centres the view on it; a click there reads it.
  const marks = report.marks || [];
  check(marks.length > 0, 'the sample has a mark to pick');
  if (marks.length > 0 && view && view.ready) {
    const mark = marks[0];
    await page.locator('a.show-in-3d[data-rank="1"]').click();
    await page.evaluate(() => new Promise((done) => requestAnimationFrame(() => requestAnimationFrame(done))));
    const centred = await page.evaluate(() => {
      const label = document.querySelector('#view3d .view3d-mark-label[data-rank="1"]');
      return { outlines: window.vmsimView3d.markOutlines, labelShown: !!label && label.style.display !== 'none' };
    });
    check(centred.outlines >= 1 && centred.labelShown, 'mark 1 is outlined (' + centred.outlines +
          ' marks outlined in its view) and labelled in the 3-D view');
    await page.locator('#view3d').screenshot({ path: path.join(shotsFolder, 'view3d_mark1.png') });
    const box = await page.locator('#view3d').boundingBox();
    await page.mouse.click(box.x + box.width / 2, box.y + box.height / 2);
    await page.evaluate(() => new Promise((done) => requestAnimationFrame(done)));
    const picked = await page.evaluate(() => ({ ...document.getElementById('view3d-pick').dataset,
                                                text: document.getElementById('view3d-pick').innerText }));
    console.log('picked: ' + picked.text.replace(/\n/g, ' | '));
    const expected = (mark.kind === 'gouge' ? -1 : 1) * mark.depth_um;
    check(picked.deviationUm !== undefined && Math.abs(Number(picked.deviationUm) - expected) < 0.01,
          'a click on the deepest mark reads its depth: ' + picked.deviationUm + ' um, report.json ' + expected.toFixed(4));
    check(picked.mark === '1', 'the picked point is in mark 1 (' + picked.mark + ')');
    check(Number(picked.programLine) === mark.line, 'the picked point names the mark\'s program line ' + mark.line +
          ' (' + picked.programLine + ')');
    const point = (picked.pointMm || '').split(',').map(Number);
    const distance = Math.hypot(...mark.deepest_point_mm.map((x, k) => x - point[k]));
    check(distance < 1e-3, 'at the mark\'s deepest point (' + distance.toExponential(2) + ' mm away)');
    await page.locator('#view3d').screenshot({ path: path.join(shotsFolder, 'view3d_mark1_picked.png') });
    await page.locator('#view3d-pick').scrollIntoViewIfNeeded();
    await page.screenshot({ path: path.join(shotsFolder, 'report_pick.png') });
  }

  // Every surface view of the selector comes up (walls, spheres, cylinders: their own meshes).
  if (view && view.ready) {
    const options = await page.locator('#view3d-view option').evaluateAll((list) => list.map((o) => o.value));
    for (const value of options.slice(1)) {
      await page.locator('#view3d-view').selectOption(value);
      await page.evaluate(() => new Promise((done) => requestAnimationFrame(() => requestAnimationFrame(done))));
      const shown = await page.evaluate(() => ({ id: window.vmsimView3d.view, triangles: window.vmsimView3d.triangles }));
      check(shown.triangles > 100, 'surface view ' + shown.id + ' comes up (' + shown.triangles + ' triangles)');
      await page.locator('#view3d').screenshot({ path: path.join(shotsFolder, 'view3d_' + shown.id + '.png') });
    }
  }

  // A page to forward: no absolute path, no code identifier in what it shows.
  const text = await page.evaluate(() => document.body.innerText);
  const absolute = text.match(/(^|[\s("'=:])\/(work|tmp|root|home|usr|opt|var|srv|mnt)\/[^\s]*/m);
  check(!absolute, 'no absolute path in the page' + (absolute ? ': ' + absolute[0].trim() : ''));
  check(!text.includes(folder), 'the result folder\'s path is not in the page');
  // Code identifiers: report.json's keys (except the part-file keys the page tells the user to
  // type), snake_case names of three words or more, and what a script shows when it goes wrong.
  const partFileKeys = new Set(['tolerance_um']);
  const keys = new Set();
  (function collect(value) {
    if (Array.isArray(value)) value.forEach(collect);
    else if (value && typeof value === 'object') {
      for (const [key, inner] of Object.entries(value)) {
        if (key.includes('_') && !partFileKeys.has(key)) keys.add(key);
        collect(inner);
      }
    }
  })(report);
  const words = new Set(text.split(/[^A-Za-z0-9_]+/));
  const shownKeys = [...keys].filter((key) => words.has(key));
  check(shownKeys.length === 0, 'no key of report.json in the page' + (shownKeys.length ? ': ' + shownKeys.join(', ') : ''));
  const identifier = text.match(/\b[a-z]+_[a-z]+_[a-z_]+\b|::|\bundefined\b|\bNaN\b|\[object Object\]|\bnull\b/);
  check(!identifier, 'no code identifier in the page' + (identifier ? ': ' + identifier[0] : ''));

  check(problems.length === 0, 'no console error, failed or network request' +
        (problems.length ? ':\n  ' + problems.join('\n  ') : ''));
  console.log('report opened to 3-D view drawn: ' + pageMs + ' ms (' + loadedMs + ' ms with chromium\'s start); ' +
              'page and scripts parsed at ' + Math.round(view ? view.scriptsLoaded : 0) + ' ms, then the viewer: ' +
              JSON.stringify(view ? view.timings : {}, (k, v) => (typeof v === 'number' ? Math.round(v) : v)));
  fs.writeFileSync(path.join(shotsFolder, 'page_text.txt'), text);
  await browser.close();
  const passed = failures.length === 0;
  console.log(passed ? 'report.browser: all checks passed' : 'report.browser: ' + failures.length + ' checks failed');
  process.exit(passed ? 0 : 1);
})().catch((error) => {
  console.error('report.browser: ' + (error && error.stack ? error.stack : error));
  process.exit(1);
});
