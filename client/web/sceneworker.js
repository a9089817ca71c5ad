/*
 * The page's scene file reader off the page's thread: a module worker
 * (review.js starts one for each file) that reads a file's bytes with
 * sceneload.js's readSceneFile, which for a big JSON file takes seconds
 * the page would otherwise spend frozen (no frames drawn, no input, no
 * messages taken). It gets the file's bytes as an ArrayBuffer
 * (transferred) and answers once: { bytes, nodes } (the scene bytes,
 * their buffer transferred back) or { error } (the reason's text, as
 * readSceneFile's SceneFileError says it). The refusal is the page's to
 * word; this file only carries it.
 */
import { readSceneFile } from './sceneload.js';

self.onmessage = (e) => {
	let scene;
	try {
		scene = readSceneFile(new Uint8Array(e.data));
	} catch (err) {
		/* Any reason, as the page says it when it reads the file itself
		 * (a SceneFileError's, or that of a failure such as memory). */
		self.postMessage({ error: String(err?.message ?? err) });
		return;
	}
	self.postMessage({ bytes: scene.bytes, nodes: scene.nodes },
		[scene.bytes.buffer]);
};
