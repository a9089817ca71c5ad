/*
 * Our side of the libfive comparison: renders a blobcast scene with
 * libfive's heightmap renderer (libfive::Heightmap, interval subdivision of
 * a voxel region seen from +z, the depth being the highest solid voxel), and
 * writes the same scene with an orthographic-like camera (far away, narrow
 * field of view, looking down -z over the same square) for blobcast's own
 * renderers, so both draw the same region at the same pixel size.
 *
 * It is built by hand against a libfive build, never by our CMake;
 * docs/benchmarks.md ("CPU tracer: SIMD, threads, libfive, Lipschitz
 * Pruning scenes") gives the command. The scene is read through our own
 * loader (libbc_blobtree), so both sides see the same primitives.
 *
 * What it translates: spheres, under the sharp union, intersection and
 * difference (min, max, max(a, -b)). libfive's operators are binary; an
 * n-ary union or intersection becomes a balanced tree of min or max (exact:
 * both are associative), a difference max(c0, -min(c1, ...)). Anything
 * else is refused with a message: this is a comparison on fig18 sharp
 * spheres, not a general exporter.
 *
 * Timing: the tree is optimized and its evaluators built once, untimed
 * (reported as setup: compiling the tape is libfive's equivalent of our
 * sync), then `reps` heightmaps are rendered and the fastest kept, by
 * process CPU time and by wall time. `--threads 1` (default) gives
 * libfive one evaluator: one render thread.
 *
 * Usage: bench_libfive SCENE.json [--size N] [--zres N] [--reps R]
 *                      [--threads T] [--ortho OUT.json]
 *   --size N      image edge in pixels (default 512)
 *   --zres N      voxels along z (default: --size)
 *   --reps R      renders, the fastest kept (default 5)
 *   --threads T   libfive evaluators / threads (default 1)
 *   --ortho OUT   write SCENE with the orthographic-like camera to OUT
 */
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

#include "libfive/eval/evaluator.hpp"
#include "libfive/render/discrete/heightmap.hpp"
#include "libfive/render/discrete/voxels.hpp"
#include "libfive/tree/tree.hpp"

extern "C" {
#include "blobcast/blobtree.h"
#include "blobcast/scene.h"
}

using libfive::Tree;

namespace {

/* The ortho-like camera stands this many scene half-widths away: the
 * footprint of a pixel then varies by under 1 % across the scene's depth
 * (for scenes about as deep as they are wide). */
constexpr double kFar = 200.0;

double cpu_ms()
{
	timespec ts;
	clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
	return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

double wall_ms()
{
	using namespace std::chrono;
	return duration<double, std::milli>(
		       steady_clock::now().time_since_epoch())
		.count();
}

[[noreturn]] void fail(const std::string &msg)
{
	std::fprintf(stderr, "bench_libfive: %s\n", msg.c_str());
	std::exit(1);
}

/* Balanced binary fold of trees[lo, hi) with min (union) or max. */
Tree fold(const std::vector<Tree> &trees, size_t lo, size_t hi, bool is_min)
{
	if (hi - lo == 1) {
		return trees[lo];
	}
	size_t mid = lo + (hi - lo) / 2;
	Tree a = fold(trees, lo, mid, is_min), b = fold(trees, mid, hi, is_min);
	return is_min ? min(a, b) : max(a, b);
}

struct open_op {
	bc_op kind;
	uint32_t left;
	std::vector<Tree> kids;
};

struct bounds {
	double lo[3] = {INFINITY, INFINITY, INFINITY};
	double hi[3] = {-INFINITY, -INFINITY, -INFINITY};
};

Tree combine(const open_op &op)
{
	switch (op.kind) {
	case BC_OP_UNION:
		return fold(op.kids, 0, op.kids.size(), true);
	case BC_OP_INTERSECTION:
		return fold(op.kids, 0, op.kids.size(), false);
	case BC_OP_DIFFERENCE:
		return max(op.kids[0],
			   -fold(op.kids, 1, op.kids.size(), true));
	default:
		fail(std::string("operator ") + bc_op_name(op.kind) +
		     " has no libfive translation here (sharp union, "
		     "intersection and difference only)");
	}
}

/* The libfive tree of t, and the bounds of its spheres. */
Tree translate(const bc_tree *t, bounds *b)
{
	bc_scene_walk w;
	bc_scene_node n;
	std::vector<open_op> stack;
	std::vector<Tree> done;
	if (bc_scene_walk_init(&w, t)) {
		fail("cannot walk the scene");
	}
	while (bc_scene_walk_next(&w, &n)) {
		if (n.is_op) {
			stack.push_back({n.op.kind, n.nchildren, {}});
			continue;
		}
		if (n.prim.kind != BC_PRIM_SPHERE) {
			fail(std::string("primitive ") +
			     bc_prim_info(n.prim.kind)->name +
			     " has no libfive translation here (spheres only)");
		}
		const float *c = n.prim.translate;
		double r = n.prim.params[0];
		Tree s = sqrt(square(Tree::X() - c[0]) +
			      square(Tree::Y() - c[1]) +
			      square(Tree::Z() - c[2])) -
			 r;
		for (int i = 0; i < 3; i++) {
			b->lo[i] = std::fmin(b->lo[i], c[i] - r);
			b->hi[i] = std::fmax(b->hi[i], c[i] + r);
		}
		/* Close every operator this primitive completes. */
		Tree cur = s;
		for (;;) {
			if (stack.empty()) {
				done.push_back(cur);
				break;
			}
			stack.back().kids.push_back(cur);
			if (--stack.back().left > 0) {
				break;
			}
			cur = combine(stack.back());
			stack.pop_back();
		}
	}
	bc_scene_walk_finish(&w);
	if (done.size() != 1 || !stack.empty()) {
		fail("the scene walk did not close its operators");
	}
	return done[0];
}

} // namespace

int main(int argc, char **argv)
{
	const char *path = nullptr, *ortho = nullptr;
	int size = 512, zres = 0, reps = 5, threads = 1;
	for (int i = 1; i < argc; i++) {
		std::string a = argv[i];
		bool more = i + 1 < argc;
		if (a == "--size" && more) {
			size = std::atoi(argv[++i]);
		} else if (a == "--zres" && more) {
			zres = std::atoi(argv[++i]);
		} else if (a == "--reps" && more) {
			reps = std::atoi(argv[++i]);
		} else if (a == "--threads" && more) {
			threads = std::atoi(argv[++i]);
		} else if (a == "--ortho" && more) {
			ortho = argv[++i];
		} else if (!path && a[0] != '-') {
			path = argv[i];
		} else {
			path = nullptr;
			break;
		}
	}
	if (!path || size < 16 || size > 8192 || reps < 1 || threads < 1 ||
	    zres < 0) {
		std::fprintf(stderr,
			     "usage: bench_libfive SCENE.json [--size N] "
			     "[--zres N] [--reps R] [--threads T] "
			     "[--ortho OUT.json]\n");
		return 2;
	}
	if (zres == 0) {
		zres = size;
	}

	bc_tree *t = bc_tree_create();
	bc_camera cam;
	bc_errinfo ei = {};
	if (!t || bc_scene_load_json(path, t, &cam, &ei)) {
		fail(std::string(path) + ": " + ei.msg);
	}
	bounds b;
	double s0 = wall_ms();
	Tree tree = translate(t, &b).optimized();
	std::vector<libfive::Evaluator *> es;
	for (int i = 0; i < threads; i++) {
		es.push_back(new libfive::Evaluator(tree));
	}
	double setup = wall_ms() - s0;

	/* A square over the scene's x-y extent (2 % margin), its z extent. */
	double cx = 0.5 * (b.lo[0] + b.hi[0]), cy = 0.5 * (b.lo[1] + b.hi[1]);
	double half = 0.51 * std::fmax(b.hi[0] - b.lo[0], b.hi[1] - b.lo[1]);
	double zlo = b.lo[2], zhi = b.hi[2];
	Eigen::Vector3f lower((float)(cx - half), (float)(cy - half),
			      (float)zlo),
		upper((float)(cx + half), (float)(cy + half), (float)zhi);
	Eigen::Vector3f res((float)(size / (2 * half)),
			    (float)(size / (2 * half)),
			    (float)(zres / (zhi - zlo)));
	libfive::Voxels vox(lower, upper, res);

	std::atomic_bool abort(false);
	double best_cpu = INFINITY, best_wall = INFINITY;
	long hits = 0;
	for (int i = 0; i < reps; i++) {
		double c0 = cpu_ms(), w0 = wall_ms();
		auto hm = libfive::Heightmap::render(es, vox, abort);
		double c = cpu_ms() - c0, w = wall_ms() - w0;
		best_cpu = std::fmin(best_cpu, c);
		best_wall = std::fmin(best_wall, w);
		hits = (long)(hm->depth > -INFINITY).count();
	}
	std::printf("libfive heightmap %s: %zux%zux%zu voxels, %u primitives, "
		    "%d thread(s): best of %d %.1f ms CPU, %.1f ms wall; "
		    "setup %.1f ms; hit %.1f%%\n",
		    path, vox.pts[0].size(), vox.pts[1].size(),
		    vox.pts[2].size(), bc_tree_prim_count(t), threads, reps,
		    best_cpu, best_wall, setup,
		    100.0 * (double)hits /
			    ((double)vox.pts[0].size() *
			     (double)vox.pts[1].size()));

	if (ortho) {
		/* Far on +z, looking down -z at the centre of the region,
		 * the field of view spanning its (possibly grown) square at
		 * the scene's middle depth. */
		double vh = 0.5 * (vox.upper.y() - vox.lower.y());
		double zc = 0.5 * (zlo + zhi), dist = kFar * vh;
		bc_camera oc = {};
		oc.eye[0] = (float)cx;
		oc.eye[1] = (float)cy;
		oc.eye[2] = (float)(zc + dist);
		oc.target[0] = (float)cx;
		oc.target[1] = (float)cy;
		oc.target[2] = (float)zc;
		oc.up[1] = 1.0f;
		oc.fov_y_deg = (float)(2.0 * std::atan(vh / dist) * 180.0 /
				       3.14159265358979323846);
		if (bc_scene_save_json(ortho, t, &oc, &ei)) {
			fail(std::string(ortho) + ": " + ei.msg);
		}
	}
	for (auto e : es) {
		delete e;
	}
	bc_tree_destroy(t);
	return 0;
}
