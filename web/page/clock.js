// The server's clock as the page reads it (a classic script: worker.js loads it with
// importScripts, the Node tests with vm). Every time on the wire (a frame set's capture, a voice
// packet's) is the server's wall clock in µs; the page keeps offset = server clock - its own
// (performance.timeOrigin + performance.now()), as the native Client does (client.cpp).
'use strict';

// The offset (µs) from one handshake: the Hello sent at `sentUs` and its Welcome, carrying the
// server's time `serverUs`, taken in at `receivedUs` (both on the page's clock). The server wrote
// its time somewhere in between, so the offset is measured against their midpoint and is uncertain
// by half the round trip; within that the clocks count as one (0): a page on the server's own
// machine, or one whose Welcome waited behind a busy start, gets no offset that is only its delay.
function handshakeClockOffsetUs(serverUs, sentUs, receivedUs) {
  const offset = serverUs - (sentUs + receivedUs) / 2;
  return Math.abs(offset) > (receivedUs - sentUs) / 2 ? offset : 0;
}
