// The page's "erase my last" (web/page/erase_last.js) in Node, without a browser: the cases of
// the native one's test (tests/session/annotation_test.cpp EraseMyLast...), on annotations made
// by hand. Synthetic: exact behaviour only.
// Run: node web/test/erase_last_test.mjs [NAME] (CTest: WebEraseLast.*); exits non-zero naming
// what failed.
import assert from 'node:assert/strict';
import path from 'node:path';
import {fileURLToPath, pathToFileURL} from 'node:url';

import {runTests} from './run_tests.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const {EraseLast, ERASE_WAIT_MS} =
    await import(pathToFileURL(path.join(here, '../page/erase_last.js')).href);

const ME = 7;
const drawn = (all, id, author, tag) => all.push({id, author, tag});

const tests = {
  // A press erases the newest of mine, not another's newer one; one press, one erase.
  ErasesTheOwnNewestOncePerPress() {
    const all = [];
    drawn(all, 1, ME, 1);
    drawn(all, 2, 9, 1);
    const e = new EraseLast();
    assert.equal(e.due(all, ME, 0), null, 'no press');
    e.pressed(10);
    assert.equal(e.due(all, ME, 10), 1);
    assert.equal(e.waiting, false);
    assert.equal(e.due(all, ME, 20), null);
  },
  // A stroke sent, the key pressed before the server numbered it: the press waits for it and
  // erases it, not the one before; something sent after the press does not hold it up.
  WaitsForWhatWasJustDrawn() {
    const all = [];
    drawn(all, 1, ME, 1);
    const e = new EraseLast();
    e.sent(2, 100);
    e.pressed(150);
    e.pressed(160);  // the same press
    assert.equal(e.due(all, ME, 170), null);
    assert.equal(e.waiting, true);
    drawn(all, 3, ME, 2);
    assert.equal(e.due(all, ME, 200), 3);
    assert.equal(e.due(all, ME, 210), null);
    e.pressed(300);
    e.sent(3, 310);
    assert.equal(e.due(all, ME, 320), 3);
  },
  // One the server refused never comes back: waited for ERASE_WAIT_MS, then the newest of mine
  // standing is erased. With none of mine standing the press is done with nothing.
  GivesUpOnARefusedOneAndEndsAPressWithNothingToErase() {
    const all = [];
    drawn(all, 3, ME, 2);
    const e = new EraseLast();
    e.sent(4, 1000);
    e.pressed(1001);
    assert.equal(e.due(all, ME, 1000 + ERASE_WAIT_MS), null);
    assert.equal(e.due(all, ME, 1001 + ERASE_WAIT_MS), 3);
    e.pressed(5000);
    assert.equal(e.due([], ME, 5000), null);
    assert.equal(e.waiting, false);
    drawn(all, 5, ME, 5);
    assert.equal(e.due(all, ME, 5010), null, 'a later drawing is not erased by it');
    e.sent(0, 6000);  // annotate before joining: nothing was sent
    e.pressed(6001);
    assert.equal(e.due(all, ME, 6001), 5);
  },
};

runTests('WebEraseLast', tests);
