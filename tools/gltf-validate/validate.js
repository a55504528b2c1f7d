// Validates glTF / GLB files with the Khronos glTF validator: one line per file with its counts of
// errors, warnings and infos, then each error and warning. Exit status 1 when any file has an
// error (or cannot be read), 2 on wrong usage.
//
//   node validate.js [--input IN.gltf] OUT.glb ...
//
// With --input, an output's error is inherited (not counted, listed as such) when the input has
// an error with the same code at the same place, e.g. an image file missing from the input's
// folder, which the output can only refer to. An error about an accessor's data is inherited only
// with the same message too (the same elements, the same values): the output's accessors hold its
// own data.
const fs = require("fs");
const path = require("path");
const validator = require("gltf-validator");

async function reportOf(file) {
  const bytes = new Uint8Array(fs.readFileSync(file));
  const report = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 100,
    externalResourceFunction: (uri) =>
      new Promise((resolve, reject) => {
        fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)), (err, data) =>
          err ? reject(err.toString()) : resolve(new Uint8Array(data)),
        );
      }),
  });
  return report;
}

const key = (m) => `${m.code} ${m.pointer}` + (m.code.startsWith("ACCESSOR_") ? ` ${m.message}` : "");

async function validate(file, inherited) {
  const report = await reportOf(file);
  const issues = report.issues;
  console.log(
    `${file}: ${issues.numErrors} errors, ${issues.numWarnings} warnings, ${issues.numInfos} infos` +
      (report.info ? `, ${report.info.totalTriangleCount} triangles, ${report.info.resources.length} resources` : ""),
  );
  let errors = 0;
  for (const m of issues.messages.filter((m) => m.severity <= 1)) {
    const old = m.severity === 0 && inherited.has(key(m));
    if (m.severity === 0 && !old) errors++;
    const kind = m.severity === 0 ? (old ? "error (inherited from the input)" : "error") : "warning";
    console.log(`  ${kind} ${m.code} at ${m.pointer || "-"}: ${m.message}`);
  }
  return errors;
}

(async () => {
  let files = process.argv.slice(2);
  const inherited = new Set();
  if (files[0] === "--input" && files.length >= 2) {
    const input = await reportOf(files[1]);
    input.issues.messages.filter((m) => m.severity === 0).forEach((m) => inherited.add(key(m)));
    files = files.slice(2);
  }
  if (files.length === 0) {
    console.error("usage: node validate.js [--input IN.gltf] FILE.glb|FILE.gltf ...");
    process.exit(2);
  }
  let failed = 0;
  for (const file of files) {
    try {
      if ((await validate(file, inherited)) > 0) failed++;
    } catch (e) {
      console.log(`${file}: could not be validated: ${e}`);
      failed++;
    }
  }
  process.exit(failed > 0 ? 1 : 0);
})();
