/* Tests of the byte helpers, the bounded buffer, the clock, the vector
 * helpers and the whole-buffer write of base/ (bytes.h, buf.h, clock.h,
 * vec.h, io.h). */
#include <errno.h>
#include <fcntl.h>
#include <float.h>
#include <stdint.h>
#include <string.h>
#include <time.h>
#include <sys/wait.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/buf.h"
#include "blobcast/bytes.h"
#include "blobcast/clock.h"
#include "blobcast/error.h"
#include "blobcast/io.h"
#include "blobcast/limits.h"
#include "blobcast/vec.h"
#include "test.h"

/* Values are little-endian whatever the host: byte 0 is least
 * significant, and put then get gives the value back. */
static void le_put_get_round_trip_in_byte_order(void)
{
	uint8_t b[8];
	bc_put_le16(b, 0x1234);
	CHECK_MEMEQ(b, "\x34\x12", 2);
	CHECK_EQ_INT(bc_get_le16(b), 0x1234);
	bc_put_le32(b, 0xdeadbeefu);
	CHECK_MEMEQ(b, "\xef\xbe\xad\xde", 4);
	CHECK(bc_get_le32(b) == 0xdeadbeefu);
	bc_put_le64(b, 0x0102030405060708ull);
	CHECK_MEMEQ(b, "\x08\x07\x06\x05\x04\x03\x02\x01", 8);
	CHECK(bc_get_le64(b) == 0x0102030405060708ull);
	bc_put_f32(b, 1.0f);
	CHECK_MEMEQ(b, "\x00\x00\x80\x3f", 4);
	CHECK(bc_get_f32(b) == 1.0f);
	bc_put_f32(b, -FLT_MAX);
	CHECK(bc_get_f32(b) == -FLT_MAX);
	/* Unaligned addresses are fine: nothing is cast. */
	uint8_t u[9] = {0};
	bc_put_le64(u + 1, UINT64_MAX - 1);
	CHECK(bc_get_le64(u + 1) == UINT64_MAX - 1);
}

/* Every read checks the bytes left first; the first failure sticks, later
 * reads give zero and do not move, and no byte past len is read. */
static void rd_cursor_is_bounded_and_sticky(void)
{
	const uint8_t bytes[7] = {1, 2, 0, 3, 0, 0, 0};
	uint8_t out[4] = {9, 9, 9, 9};
	struct bc_rd r = bc_rd_init(bytes, sizeof(bytes));
	CHECK_EQ_INT(bc_rd_u8(&r), 1);
	CHECK_EQ_INT(bc_rd_u16(&r), 2);
	CHECK_EQ_INT(bc_rd_u32(&r), 3);
	CHECK_EQ_INT(r.err, 0);
	CHECK_EQ_INT(bc_rd_left(&r), 0);
	CHECK_EQ_INT(bc_rd_u8(&r), 0);
	CHECK_EQ_INT(r.err, BC_EPROTO_TRUNCATED);
	CHECK_EQ_INT(r.pos, 7);

	r = bc_rd_init(bytes, 3);
	CHECK(bc_rd_u32(&r) == 0);
	CHECK_EQ_INT(r.err, BC_EPROTO_TRUNCATED);
	CHECK_EQ_INT(r.pos, 0);
	/* Sticky: a read that would fit now fails too. */
	CHECK_EQ_INT(bc_rd_u8(&r), 0);
	CHECK_EQ_INT(r.pos, 0);
	CHECK_EQ_INT(bc_rd_bytes(&r, out, 2), BC_EPROTO_TRUNCATED);
	CHECK_MEMEQ(out, "\0\0\x09\x09", 4);

	/* A length near SIZE_MAX cannot wrap the bounds test. */
	r = bc_rd_init(bytes, sizeof(bytes));
	bc_rd_u8(&r);
	CHECK(bc_rd_take(&r, SIZE_MAX) == NULL);
	CHECK_EQ_INT(r.err, BC_EPROTO_TRUNCATED);

	r = bc_rd_init(bytes, sizeof(bytes));
	CHECK_EQ_INT(bc_rd_bytes(&r, out, 4), 0);
	CHECK_MEMEQ(out, bytes, 4);
	CHECK(bc_rd_f32(&r) == 0.0f);
	CHECK_EQ_INT(r.err, BC_EPROTO_TRUNCATED);
}

/* Appends stay under the ceiling: going over frees the contents, and the
 * failure sticks until the buffer is initialised again. */
static void buf_ceiling_fails_and_sticks(void)
{
	struct bc_buf b;
	uint8_t *out;
	size_t len;
	bc_buf_init(&b, 10);
	CHECK_EQ_INT(bc_buf_append(&b, "hello", 5), 0);
	CHECK_EQ_INT(bc_buf_printf(&b, "%d%s", 42, "abc"), 0);
	CHECK_EQ_INT(b.len, 10);
	CHECK(b.cap <= 11);
	CHECK_EQ_INT(bc_buf_append(&b, "x", 1), BC_ELIMIT);
	CHECK(b.data == NULL && b.len == 0);
	CHECK_EQ_INT(bc_buf_append(&b, "", 0), BC_ELIMIT);
	CHECK_EQ_INT(bc_buf_printf(&b, "y"), BC_ELIMIT);
	CHECK_EQ_INT(bc_buf_take(&b, &out, &len), BC_ELIMIT);
	CHECK(out == NULL && len == 0);
	bc_buf_finish(&b);

	/* A reserve over the ceiling fails without allocating. */
	bc_buf_init(&b, 1u << 20);
	CHECK_EQ_INT(bc_buf_reserve(&b, SIZE_MAX), BC_ELIMIT);
	bc_buf_finish(&b);

	/* take hands over NUL-terminated contents and empties the buffer. */
	bc_buf_init(&b, 1u << 20);
	for (int i = 0; i < 1000; i++) {
		REQUIRE(bc_buf_printf(&b, "%03d,", i) == 0);
	}
	CHECK_EQ_INT(b.len, 4000);
	CHECK_EQ_INT(bc_buf_take(&b, &out, &len), 0);
	CHECK_EQ_INT(len, 4000);
	CHECK_MEMEQ(out + 3992, "998,999,", 8);
	CHECK(out[4000] == '\0');
	CHECK(b.data == NULL && b.len == 0);
	bc_free(out);
	/* An empty buffer takes as an empty string. */
	CHECK_EQ_INT(bc_buf_take(&b, &out, &len), 0);
	CHECK(out && len == 0 && out[0] == '\0');
	bc_free(out);
	bc_buf_finish(&b);
	bc_buf_finish(NULL);
}

/* Out of memory is sticky too and leaks nothing (ASan checks). */
static void buf_out_of_memory_is_sticky(void)
{
	struct bc_buf b;
	bc_buf_init(&b, 1u << 20);
	REQUIRE(bc_buf_append(&b, "abc", 3) == 0);
	bc_alloc_fail_after(1);
	CHECK_EQ_INT(bc_buf_reserve(&b, 4096), BC_ENOMEM);
	bc_alloc_fail_after(0);
	CHECK(b.data == NULL);
	CHECK_EQ_INT(bc_buf_append(&b, "d", 1), BC_ENOMEM);
	bc_buf_finish(&b);
}

/* The clock moves forward and ms is ns / 10^6. */
/* bc_utf8_encode writes every character as strict UTF-8 that
 * bc_utf8_check takes whole, at the length of RFC 3629's table, and no
 * bytes for surrogates or code points above U+10FFFF. */
static void utf8_encode_round_trips(void)
{
	static const uint32_t edges[] = {0x01,   0x7f,    0x80,     0x7ff,
	                                 0x800,  0xd7ff,  0xe000,   0xfffd,
	                                 0xffff, 0x10000, 0x10ffff, 0xe9};
	char u[4] = {'x', 'x', 'x', 'x'};
	for (size_t i = 0; i < sizeof(edges) / sizeof(edges[0]); i++) {
		uint32_t cp = edges[i];
		size_t n = bc_utf8_encode(cp, u);
		size_t want = cp < 0x80u      ? 1
		              : cp < 0x800u   ? 2
		              : cp < 0x10000u ? 3
		                              : 4;
		CHECK_EQ_INT(n, want);
		CHECK_EQ_INT(bc_utf8_check((const uint8_t *)u, n), n);
	}
	CHECK_EQ_INT(bc_utf8_encode(0xe9, u), 2);
	CHECK(memcmp(u, "\xc3\xa9", 2) == 0);
	CHECK_EQ_INT(bc_utf8_encode(0x1f600, u), 4);
	CHECK(memcmp(u, "\xf0\x9f\x98\x80", 4) == 0);
	for (uint32_t cp = 0xd800; cp < 0xe000; cp += 0x7f) {
		CHECK_EQ_INT(bc_utf8_encode(cp, u), 0);
	}
	CHECK_EQ_INT(bc_utf8_encode(0xdfff, u), 0);
	CHECK_EQ_INT(bc_utf8_encode(0x110000, u), 0);
	CHECK_EQ_INT(bc_utf8_encode(0xffffffffu, u), 0);
	/* Every character of the first three planes, each checked whole. */
	for (uint32_t cp = 1; cp < 0x30000u; cp++) {
		size_t n = bc_utf8_encode(cp, u);
		if (cp >= 0xd800u && cp < 0xe000u) {
			continue;
		}
		if (n == 0 || bc_utf8_check((const uint8_t *)u, n) != n) {
			CHECK_EQ_INT(cp,
			             0); /* names the first one that fails */
			break;
		}
	}
}

/* bc_str_appendf writes within its array, cut and terminated at its end,
 * and reports the length it reached. */
static void str_appendf_stays_within_cap(void)
{
	char s[8];
	size_t len = 0;
	memset(s, 'x', sizeof(s));
	len = bc_str_appendf(s, sizeof(s), len, "%d", 12);
	CHECK_EQ_INT(len, 2);
	CHECK_STREQ(s, "12");
	len = bc_str_appendf(s, sizeof(s), len, "%s", "abc");
	CHECK_EQ_INT(len, 5);
	CHECK_STREQ(s, "12abc");
	/* Cut: 7 bytes and the NUL, length cap - 1. */
	len = bc_str_appendf(s, sizeof(s), len, "%s", "defgh");
	CHECK_EQ_INT(len, 7);
	CHECK_STREQ(s, "12abcde");
	/* Full: nothing more is written. */
	CHECK_EQ_INT(bc_str_appendf(s, sizeof(s), len, "%s", "z"), 7);
	CHECK_STREQ(s, "12abcde");
	/* No room at all, or a length past the array: unchanged. */
	CHECK_EQ_INT(bc_str_appendf(s, 0, 0, "%s", "z"), 0);
	CHECK_EQ_INT(bc_str_appendf(s, sizeof(s), 9, "%s", "z"), 9);
	CHECK_STREQ(s, "12abcde");
}

static void clock_is_monotonic(void)
{
	uint64_t a = bc_clock_ns(), b;
	double ms;
	struct timespec pause = {0, 2000000};
	CHECK(a > 0);
	nanosleep(&pause, NULL);
	b = bc_clock_ns();
	CHECK(b - a >= 2000000u);
	ms = bc_clock_ms();
	CHECK(ms >= (double)b / 1e6 && ms < (double)b / 1e6 + 1000.0);
}

static void vec_helpers_follow_the_right_hand(void)
{
	float x[3] = {1, 0, 0}, y[3] = {0, 1, 0}, z[3], v[3] = {3, 4, 0};
	float q[4], r[4], out[3];
	bc_v3_cross(x, y, z);
	CHECK(z[0] == 0.0f && z[1] == 0.0f && z[2] == 1.0f);
	CHECK(bc_v3_dot(x, y) == 0.0f);
	CHECK_NEAR(bc_v3_normalize(v), 5.0, 1e-6);
	CHECK_NEAR(v[0], 0.6, 1e-6);
	CHECK_NEAR(bc_v3_len(v), 1.0, 1e-6);
	float zero[3] = {0, 0, 0};
	CHECK(bc_v3_normalize(zero) == 0.0f && zero[0] == 0.0f);
	bc_v3_sub(v, v, out);
	CHECK(out[0] == 0.0f && out[1] == 0.0f);
	/* A quarter turn about z takes x to y. */
	bc_quat_axis_angle(q, 0, 0, 1, 1.5707963f);
	bc_quat_rotate(q, x, out);
	CHECK_NEAR(out[0], 0.0, 1e-6);
	CHECK_NEAR(out[1], 1.0, 1e-6);
	/* Two quarter turns compose to a half turn, in place. */
	bc_quat_mul(q, q, r);
	bc_quat_mul(r, q, r);
	bc_quat_rotate(r, x, out);
	CHECK_NEAR(out[0], 0.0, 1e-5);
	CHECK_NEAR(out[1], -1.0, 1e-5);
	/* mul applies b first: about x then about z sends y to -x... */
	float qx[4], qz[4], qzx[4];
	bc_quat_axis_angle(qx, 1, 0, 0, 1.5707963f);
	bc_quat_axis_angle(qz, 0, 0, 1, 1.5707963f);
	bc_quat_mul(qz, qx, qzx);
	bc_quat_rotate(qzx, y, out);
	/* y -> (about x) z -> (about z) z. */
	CHECK_NEAR(out[2], 1.0, 1e-5);
	bc_quat_rotate(qzx, z, out);
	/* z -> (about x) -y -> (about z) x. */
	CHECK_NEAR(out[0], 1.0, 1e-5);
	r[0] = r[1] = r[2] = r[3] = 0.0f;
	bc_quat_normalize(r);
	CHECK(r[3] == 1.0f && r[0] == 0.0f);
	r[0] = 2.0f;
	bc_quat_normalize(r);
	CHECK_NEAR(r[0] * r[0] + r[3] * r[3], 1.0, 1e-6);
	/* normalize_div is the division itself, bit for bit (the renderers'
	 * images depend on it), over vectors where a product with the
	 * reciprocal rounds differently; zero is left alone. */
	uint32_t seed = 12345u, differs = 0;
	for (int i = 0; i < 1000; i++) {
		float a[3], b[3], c[3];
		for (int k = 0; k < 3; k++) {
			seed = seed * 1664525u + 1013904223u;
			c[k] = (float)(seed >> 8) / 65536.0f - 128.0f;
		}
		memcpy(a, c, sizeof a);
		memcpy(b, c, sizeof b);
		float n = bc_v3_len(c);
		bc_v3_normalize_div(a);
		bc_v3_normalize(b);
		for (int k = 0; k < 3; k++) {
			CHECK(a[k] == c[k] / n);
			differs += a[k] != b[k];
		}
	}
	CHECK(differs > 0); /* the two rules are not the same */
	float z0[3] = {0, 0, 0};
	bc_v3_normalize_div(z0);
	CHECK(z0[0] == 0.0f && z0[1] == 0.0f && z0[2] == 0.0f);
}

/* The node limit is the 22-bit field's "none" value. */
static void limits_hold_their_relations(void)
{
	CHECK(BC_LIMIT_NODES == 4194303u);
	CHECK((uint64_t)BC_LIMIT_DIM * BC_LIMIT_DIM * 4u <= UINT32_MAX + 1ull);
}

/* bc_write_all writes a buffer larger than a pipe holds at once (the
 * reader drains it in another process), and fails with errno on a
 * descriptor that takes nothing. */
static void write_all_writes_everything_or_says_why(void)
{
	enum { N = 1 << 20 };
	static uint8_t out[N], in[N];
	int fds[2], devnull = open("/dev/null", O_RDONLY);
	size_t got = 0;
	pid_t pid;
	for (size_t i = 0; i < N; i++) {
		out[i] = (uint8_t)(i * 131u + 7u);
	}
	REQUIRE(pipe(fds) == 0);
	pid = fork();
	REQUIRE(pid >= 0);
	if (pid == 0) {
		close(fds[0]);
		_exit(bc_write_all(fds[1], out, N) ? 0 : 1);
	}
	close(fds[1]);
	for (;;) {
		ssize_t n = read(fds[0], in + got, N - got);
		if (n <= 0) {
			break;
		}
		got += (size_t)n;
	}
	close(fds[0]);
	{
		int status = 0;
		CHECK(waitpid(pid, &status, 0) == pid);
		CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 0);
	}
	CHECK_EQ_INT((int)got, N);
	CHECK(memcmp(in, out, N) == 0);
	REQUIRE(devnull >= 0);
	errno = 0;
	CHECK(!bc_write_all(devnull, out, 16)); /* opened for reading */
	CHECK_EQ_INT(errno, EBADF);
	CHECK(bc_write_all(devnull, out, 0)); /* nothing to write */
	close(devnull);
}

static const struct bc_test tests[] = {
    {"le_put_get_round_trip_in_byte_order",
     le_put_get_round_trip_in_byte_order},
    {"rd_cursor_is_bounded_and_sticky", rd_cursor_is_bounded_and_sticky},
    {"buf_ceiling_fails_and_sticks", buf_ceiling_fails_and_sticks},
    {"buf_out_of_memory_is_sticky", buf_out_of_memory_is_sticky},
    {"str_appendf_stays_within_cap", str_appendf_stays_within_cap},
    {"utf8_encode_round_trips", utf8_encode_round_trips},
    {"clock_is_monotonic", clock_is_monotonic},
    {"vec_helpers_follow_the_right_hand", vec_helpers_follow_the_right_hand},
    {"limits_hold_their_relations", limits_hold_their_relations},
    {"write_all_writes_everything_or_says_why",
     write_all_writes_everything_or_says_why},
};
BC_TEST_MAIN(tests)
