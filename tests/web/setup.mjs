/*
 * ctest fixture for the browser tests: installs playwright-core into
 * tests/web/node_modules from the committed package-lock.json when it is
 * missing (npm ci; the browser itself is Debian's chromium and is never
 * downloaded). Without npm, or when the install fails, it says so and
 * succeeds anyway: the e2e test then skips, naming what is missing.
 */
import { spawnSync } from 'node:child_process';
import { existsSync } from 'node:fs';
import { join } from 'node:path';

import { HERE, which } from './harness.mjs';

if (existsSync(join(HERE, 'node_modules', 'playwright-core', 'package.json'))) {
	process.exit(0);
}
const npm = which('npm');
if (!npm) {
	console.log('setup: npm not found; the browser e2e test will skip');
	process.exit(0);
}
console.log('setup: npm ci --prefix tests/web');
const r = spawnSync(npm, ['ci', '--prefix', HERE, '--no-audit', '--no-fund'],
	{ stdio: 'inherit', env: { ...process.env,
		PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD: '1' } });
if (r.status !== 0) {
	console.log(`setup: npm ci failed (${r.status}); the browser e2e test ` +
		'will skip');
}
process.exit(0);
