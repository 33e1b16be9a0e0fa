// SPDX-License-Identifier: GPL-3.0-or-later
// Validates a glTF 2.0 asset (.glb or .gltf) with the Khronos glTF validator,
// loading its external resources (buffers, images) relative to the file, so a
// missing or unreadable texture is an error.
//
//   node validate.mjs [--all] FILE...
//
// Prints "FILE: N errors, N warnings, N infos" per file, then each error (with --all also
// each warning, info and hint, and the external resources that were loaded).
// Exit status: 0 when no asset has errors, 1 when one has errors (or the
// validator cannot read it as glTF at all), 2 on usage or I/O problems.
//
// Needs node >= 18 and `npm ci` in this folder (node_modules, see package.json).
// Runs offline once installed.

import { readFile } from 'node:fs/promises';
import path from 'node:path';
import { createRequire } from 'node:module';

const require = createRequire(import.meta.url);
const kMaxPrinted = 100;  // issues printed per severity; the counts are always complete

function usage(message) {
  if (message) console.error(`validate.mjs: ${message}`);
  console.error('usage: node validate.mjs [--all] FILE.glb|FILE.gltf...');
  process.exit(2);
}

const args = process.argv.slice(2);
let all = false;
const files = [];
for (const a of args) {
  if (a === '--all') all = true;
  else if (a === '-h' || a === '--help') usage();
  else if (a.startsWith('-') && a !== '-') usage(`unknown option ${a}`);
  else files.push(a);
}
if (files.length === 0) usage('expected at least one file');

let validator;
try {
  validator = require('gltf-validator');
} catch (e) {
  console.error(`validate.mjs: cannot load the gltf-validator package (run "npm ci" in ${path.dirname(new URL(import.meta.url).pathname)}): ${e.message}`);
  process.exit(2);
}

async function validateOne(file) {
  let bytes;
  try {
    bytes = await readFile(file);
  } catch (e) {
    console.error(`${file}: cannot read: ${e.message}`);
    return 2;
  }

  const baseDir = path.dirname(path.resolve(file));
  const loaded = [];

  // The validator passes each external resource's URI as written in the asset
  // (relative, percent-encoded). Only relative references are resolved; anything
  // with a scheme (http:, file:, ...) is refused, which the validator reports as an
  // error: a debug asset must be self-contained next to its textures.
  async function loadExternal(uri) {
    if (/^[A-Za-z][A-Za-z0-9+.-]*:/.test(uri)) {
      throw new Error(`${uri}: only relative URIs are loaded`);
    }
    let decoded;
    try {
      decoded = decodeURIComponent(uri);
    } catch (e) {
      throw new Error(`${uri}: malformed percent-encoding`);
    }
    const resolved = path.resolve(baseDir, decoded);
    try {
      const data = await readFile(resolved);
      loaded.push(resolved);
      return new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
    } catch (e) {
      throw new Error(`${uri}: cannot read ${resolved}: ${e.code || e.message}`);
    }
  }

  let report;
  try {
    report = await validator.validateBytes(new Uint8Array(bytes.buffer, bytes.byteOffset, bytes.byteLength), {
      uri: file,
      maxIssues: 0,  // unlimited: the counts must be exact
      writeTimestamp: false,
      externalResourceFunction: loadExternal,
    });
  } catch (e) {
    // Rejection: the validator could not even detect glTF or GLB.
    console.log(`${file}: not a glTF asset: ${e}`);
    return 1;
  }

  const issues = report.issues;
  console.log(`${file}: ${issues.numErrors} errors, ${issues.numWarnings} warnings, ${issues.numInfos} infos`);
  const severityName = ['error', 'warning', 'info', 'hint'];
  const printed = [0, 0, 0, 0];
  for (const m of issues.messages) {
    if (m.severity !== 0 && !all) continue;
    if (printed[m.severity]++ >= kMaxPrinted) continue;
    const where = m.pointer ? ` ${m.pointer}` : (m.offset !== undefined ? ` @${m.offset}` : '');
    console.log(`  ${severityName[m.severity] ?? m.severity} ${m.code}${where}: ${m.message}`);
  }
  for (let s = 0; s < 4; ++s) {
    if (printed[s] > kMaxPrinted) console.log(`  ... ${printed[s] - kMaxPrinted} more ${severityName[s]} messages`);
  }
  if (issues.truncated) console.log('  (the validator truncated its issue list)');
  if (all) {
    console.log(`  loaded ${loaded.length} external resource(s) relative to ${baseDir}`);
  }
  return issues.numErrors === 0 ? 0 : 1;
}

let status = 0;
for (const file of files) status = Math.max(status, await validateOne(file));
process.exit(status);
