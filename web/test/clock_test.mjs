// The page's reading of the server's clock (web/page/clock.js) in Node: handshakes with the
// server's time written at a known point between the Hello and the Welcome. Synthetic times, in µs.
// Run: node web/test/clock_test.mjs [NAME] (CTest: WebClock.*); exits non-zero naming what failed.
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import vm from 'node:vm';
import {fileURLToPath} from 'node:url';

import {runTests} from './run_tests.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
vm.runInThisContext(fs.readFileSync(path.join(here, '../page/clock.js'), 'utf8'));
const offsetOf = globalThis.handshakeClockOffsetUs;

runTests('WebClock', {
  // One machine, one clock: the server answered at once, and the page's worker took the Welcome in
  // 120 ms later (a busy start). Read as "server time - time received", the page put the server
  // 120 ms behind itself, and every capture -> presented figure came out 120 ms short.
  AWelcomeTakenInLateOnOneClockGivesNoOffset() {
    const sent = 5_000_000, server = sent + 2_000, received = server + 120_000;
    assert.equal(offsetOf(server, sent, received), 0);
  },
  // The server's clock 3 s ahead, a 40 ms round trip with the server's time written halfway:
  // the offset is the clocks', exactly.
  AnotherMachinesClockIsMeasuredFromTheMidpoint() {
    const sent = 1_000_000, received = sent + 40_000, server = sent + 20_000 + 3_000_000;
    assert.equal(offsetOf(server, sent, received), 3_000_000);
    assert.equal(offsetOf(sent + 20_000 - 250_000, sent, received), -250_000);
  },
  // An offset within half the round trip cannot be told from the delay: the clocks count as one,
  // as the native Client's handshake decides (client.cpp).
  AnOffsetWithinHalfTheRoundTripCountsAsNone() {
    const sent = 0, received = 30_000;
    assert.equal(offsetOf(15_000 + 14_999, sent, received), 0);
    assert.equal(offsetOf(15_000 + 15_001, sent, received), 15_001);
  },
});
