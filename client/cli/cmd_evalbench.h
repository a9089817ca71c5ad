/*
 * `blobcast eval-bench`: measures the adaptive CSG evaluator of render/svo
 * on a scene -- pruning cost, pruned and unpruned evaluation time per point,
 * the speedup, the octree's shape and memory -- and prints them as JSON.
 */
#ifndef BLOBCAST_CLI_CMD_EVALBENCH_H
#define BLOBCAST_CLI_CMD_EVALBENCH_H

/* Runs `blobcast eval-bench SCENE [options]`. argv[0] is the command word
 * ("eval-bench"); argv[1..argc) are its arguments. Prints the JSON report
 * on stdout, messages on stderr. Returns the process exit status: 0 on
 * success (and for --help), 1 when loading or measuring fails, 2 for a
 * usage error. */
int bc_cli_eval_bench(int argc, char **argv);

#endif
