// Runs a Node test file's tests as CTest runs them, one at a time (`node FILE.mjs NAME`) or all
// (`node FILE.mjs`): each prints a googletest-like line under `suite`; the process exits non-zero
// naming what failed, or an unknown NAME.
export function runTests(suite, tests) {
  const filter = process.argv[2];
  if (filter && !(filter in tests)) {
    console.log(`[  FAILED  ] ${suite}.${filter}: no such test`);
    process.exit(1);
  }
  let failed = 0;
  for (const [name, test] of Object.entries(tests)) {
    if (filter && filter !== name) continue;
    try {
      test();
      console.log(`[       OK ] ${suite}.${name}`);
    } catch (err) {
      ++failed;
      console.log(`[  FAILED  ] ${suite}.${name}: ${err.message}`);
    }
  }
  process.exit(failed ? 1 : 0);
}
