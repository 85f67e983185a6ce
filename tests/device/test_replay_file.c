/*
 * CMocka suite of aacmm-sim's replay-file parser (firmware/ports/posix/
 * replay_file.h), fed as a hostile file would be: each case is written to a
 * temporary file, loaded, and either its poses or its one-line error (which
 * line, what is wrong) checked against what the contract promises. Built with
 * gcc and clang and run under ASan+UBSan (mk/device.mk: test-device-replay).
 */
#define _POSIX_C_SOURCE 200809L
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "replay_file.h"

#define CPR32 4294967296ull /* 2^32: every 32-bit count is valid */

static char g_dir[] = "/tmp/aacmm-replay-XXXXXX";
static char g_path[sizeof g_dir + 32];

static int setup(void **state)
{
    (void)state;
    if (mkdtemp(g_dir) == NULL) {
        return -1;
    }
    snprintf(g_path, sizeof g_path, "%s/replay.txt", g_dir);
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    (void)unlink(g_path);
    return rmdir(g_dir);
}

/* Write len bytes of text as the replay file (len, not strlen: NUL bytes). */
static const char *write_file(const char *text, size_t len)
{
    FILE *f = fopen(g_path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(text, 1, len, f), len);
    assert_int_equal(fclose(f), 0);
    return g_path;
}

static const char *write_text(const char *text)
{
    return write_file(text, strlen(text));
}

/* The file must be refused: -1, outputs untouched, and err one line that
 * contains `want` (a "PATH:LINE:" prefix is checked by the callers that name
 * a line). */
static void expect_error(const char *path, uint64_t cpr, const char *want)
{
    uint32_t sentinel[1] = {0xDEADBEEFu};
    uint32_t *poses = sentinel;
    uint32_t n = 77u;
    unsigned k = 99u;
    char err[512];
    memset(err, 'x', sizeof err);
    err[sizeof err - 1] = '\0';
    if (replay_file_load(path, cpr, &poses, &n, &k, err, sizeof err) != -1) {
        fail_msg("accepted %s, expected an error with '%s'", path, want);
    }
    assert_ptr_equal(poses, sentinel);
    assert_int_equal(n, 77u);
    assert_int_equal(k, 99u);
    assert_null(strchr(err, '\n'));
    if (strstr(err, want) == NULL) {
        fail_msg("error '%s' does not contain '%s'", err, want);
    }
}

/* The same for a line of the temporary file: "PATH:LINE: ..." with want. */
static void expect_line_error(const char *text, uint64_t cpr, unsigned line, const char *want)
{
    char prefix[sizeof g_path + 16];
    uint32_t *poses = NULL;
    uint32_t n = 0;
    unsigned k = 0;
    char err[512];
    write_text(text);
    snprintf(prefix, sizeof prefix, "%s:%u: ", g_path, line);
    assert_int_equal(replay_file_load(g_path, cpr, &poses, &n, &k, err, sizeof err), -1);
    if (strncmp(err, prefix, strlen(prefix)) != 0 || strstr(err, want) == NULL) {
        fail_msg("file '%s': error '%s', expected '%s...%s'", text, err, prefix, want);
    }
    expect_error(g_path, cpr, want);
}

/* The file must give want_n poses of want_k joints: want, pose after pose. */
static void expect_poses_k(const char *text, uint64_t cpr, unsigned want_k, const uint32_t *want,
                           uint32_t want_n)
{
    uint32_t *poses = NULL;
    uint32_t n = 0;
    unsigned k = 0;
    char err[256] = "";
    write_text(text);
    if (replay_file_load(g_path, cpr, &poses, &n, &k, err, sizeof err) != 0) {
        fail_msg("file '%s' refused: %s", text, err);
    }
    assert_int_equal(k, want_k);
    assert_int_equal(n, want_n);
    assert_memory_equal(poses, want, (size_t)want_n * want_k * sizeof *want);
    free(poses);
}

static void expect_poses(const char *text, uint64_t cpr, const uint32_t *want, uint32_t want_n)
{
    expect_poses_k(text, cpr, AACMM_JOINTS, want, want_n);
}

static void test_plain_poses(void **state)
{
    static const uint32_t two[] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
    static const uint32_t edge[] = {0, 0, 0, 0, 0, 4294967295u};
    static const uint32_t below[] = {4095, 0, 1, 2, 3, 4094};
    (void)state;
    expect_poses("1 2 3 4 5 6\n7 8 9 10 11 12\n", CPR32, two, 2);
    /* commas, tabs, comments, blank lines, CRLF, no final line end */
    expect_poses("# poses\n\n1,2,3,4,5,6   # first\r\n\t \r\n7, 8,\t9 ,10,11,12", CPR32, two, 2);
    expect_poses("0 0 0 0 0 4294967295\n", CPR32, edge, 1);
    expect_poses("4095 0 1 2 3 4094\n", 4096u, below, 1);
}

static void test_csv_poses(void **state)
{
    static const uint32_t want[] = {10, 20, 30, 40, 50, 60, 11, 21, 31, 41, 51, 61};
    (void)state;
    /* columns in any order, others ignored, a faulty row (flags bit 1) skipped */
    expect_poses("seq,count6,count5,count4,count3,count2,count1,flags\r\n"
                 "1,60,50,40,30,20,10,0\r\n"
                 "2,99,99,99,99,99,99,2\r\n"
                 "\r\n"
                 "3,61,51,41,31,21,11,1\r\n",
                 CPR32, want, 2);
    expect_poses("count1 , count2,count3,\tcount4,count5,count6 \n10,20,30,40,50,60\n"
                 "11,21,31,41,51,61",
                 CPR32, want, 2);
}

static void test_missing_and_empty(void **state)
{
    char missing[sizeof g_dir + 32];
    (void)state;
    snprintf(missing, sizeof missing, "%s/no-such-file.txt", g_dir);
    expect_error(missing, CPR32, "cannot open replay file");
    expect_error(missing, CPR32, "No such file or directory");
    expect_error(g_dir, CPR32, "replay file"); /* a directory: cannot read it */
    expect_error(write_text(""), CPR32, "no poses");
    expect_error(write_text("\n\n   \n"), CPR32, "no poses");
    expect_error(write_text("# only\n# comments\n"), CPR32, "no poses");
    expect_error(write_text("count1,count2,count3,count4,count5,count6\n"), CPR32, "no poses");
    expect_error(write_text("count1,count2,count3,count4,count5,count6,flags\n"
                            "1,2,3,4,5,6,2\n"),
                 CPR32, "no poses"); /* every row faulty */
}

static void test_malformed_lines(void **state)
{
    (void)state;
    expect_line_error("1 2 3 4 5 6\n1 2 3 4 5\n", CPR32, 2, "5 counts, expected 6 as on line 1");
    expect_line_error("1 2 3 4 5 6\n1 2 3 4 5 6 7\n", CPR32, 2, "more than 6 counts, as on line 1");
    expect_line_error("1 2 3 4 5 6 7 8\n", CPR32, 1, "more than 7 counts (a pose has 4 to 7)");
    expect_line_error("1 2 3 4 5 6\n\n1 2 x 4 5 6\n", CPR32, 3, "expected an unsigned count");
    expect_line_error("1 2 3 4 5 6\n-1 2 3 4 5 6\n", CPR32, 2, "expected an unsigned count");
    expect_line_error("1 2 3 4 5 +6\n", CPR32, 1, "expected an unsigned count");
    expect_line_error("1 2 3.5 4 5 6\n", CPR32, 1, "bad count");
    expect_line_error("1 2 3 4 5 6x\n", CPR32, 1, "bad count");
    expect_line_error("1 2 3 4 5 0x10\n", CPR32, 1, "bad count");
    expect_line_error("1;2;3;4;5;6\n", CPR32, 1, "bad count");
    expect_line_error("1 2 3 4 5 6\n count1\n", CPR32, 2, "expected an unsigned count");
}

static void test_nan_inf_exponents(void **state)
{
    (void)state;
    expect_line_error("1 2 3 4 5 6\nnan 2 3 4 5 6\n", CPR32, 2, "expected an unsigned count");
    expect_line_error("1 2 3 4 5 6\n1 2 3 4 5 NaN\n", CPR32, 2, "expected an unsigned count");
    expect_line_error("1 2 3 4 5 6\n1 2 3 4 5 inf\n", CPR32, 2, "expected an unsigned count");
    expect_line_error("1 2 3 4 5 1e3\n", CPR32, 1, "bad count");
    /* a first line of letters is a CSV header: without count1..6 it is refused */
    expect_line_error("nan nan nan nan nan nan\n", CPR32, 1, "no column count1");
    expect_line_error("count1,count2,count3,count4,count5,count6\n1,2,nan,4,5,6\n", CPR32, 2,
                      "count3: expected an unsigned count, got 'nan'");
    expect_line_error("count1,count2,count3,count4,count5,count6\n1,2,3,4,5,-inf\n", CPR32, 2,
                      "count6");
    expect_line_error("count1,count2,count3,count4,count5,count6\n1,2,3,4,5,6.0\n", CPR32, 2,
                      "count6");
    expect_line_error("count1,count2,count3,count4,count5,count6,flags\n1,2,3,4,5,6,nan\n",
                      CPR32, 2, "bad flags");
}

static void test_huge_values(void **state)
{
    (void)state;
    /* at or above cpr */
    expect_line_error("1 2 3 4 5 4294967296\n", CPR32, 1, "count 4294967296 is not below");
    expect_line_error("4096 0 0 0 0 0\n", 4096u, 1, "count 4096 is not below 4096");
    expect_line_error("count1,count2,count3,count4,count5,count6\n0,0,0,0,4096,0\n", 4096u, 2,
                      "count5 4096 is not below 4096");
    /* 2^64 - 1 still parses (and is refused by cpr); 2^64 and beyond overflow */
    expect_line_error("18446744073709551615 0 0 0 0 0\n", CPR32, 1, "is not below");
    expect_line_error("18446744073709551616 0 0 0 0 0\n", CPR32, 1, "bad count");
    expect_line_error("1 2 3 4 5 99999999999999999999999999999999999999999\n", CPR32, 1,
                      "bad count");
    expect_line_error("count1,count2,count3,count4,count5,count6\n"
                      "1,2,3,4,5,18446744073709551616\n",
                      CPR32, 2, "count6: expected an unsigned count");
    expect_line_error("count1,count2,count3,count4,count5,count6,flags\n"
                      "1,2,3,4,5,6,18446744073709551616\n",
                      CPR32, 2, "bad flags");
}

static void test_long_lines_columns_nul(void **state)
{
    static char text[12000];
    size_t i, k;
    (void)state;
    /* a line longer than the 4095-byte buffer, in either format, anywhere */
    memset(text, ' ', 5000);
    memcpy(text + 5000, "1 2 3 4 5 6\n", 13);
    expect_line_error(text, CPR32, 1, "line too long");
    k = (size_t)sprintf(text, "1 2 3 4 5 6\n");
    memset(text + k, '7', 5000);
    text[k + 5000] = '\0';
    expect_line_error(text, CPR32, 2, "line too long");
    k = (size_t)sprintf(text, "count1,count2,count3,count4,count5,count6\n");
    memset(text + k, '0', 4500);
    text[k + 4500] = '\0';
    expect_line_error(text, CPR32, 2, "line too long");
    /* exactly 4094 bytes and its line end still fit */
    memset(text, ' ', 4094 - 11);
    memcpy(text + 4094 - 11, "1 2 3 4 5 6\n", 13);
    {
        static const uint32_t want[] = {1, 2, 3, 4, 5, 6};
        expect_poses(text, CPR32, want, 1);
    }
    /* too many columns: in the header, in a row */
    k = 0;
    for (i = 0; i < 70; i++) {
        k += (size_t)sprintf(text + k, i ? ",c%zu" : "c%zu", i);
    }
    text[k] = '\0';
    expect_line_error(text, CPR32, 1, "more than 64 columns");
    k = (size_t)sprintf(text, "count1,count2,count3,count4,count5,count6\n");
    for (i = 0; i < 70; i++) {
        k += (size_t)sprintf(text + k, i ? ",1" : "1");
    }
    expect_line_error(text, CPR32, 2, "more than 64 columns");
    expect_line_error("count1,count2,count3,count4,count5,count6\n1,2,3\n", CPR32, 2,
                      "3 fields, the header has more");
    /* a NUL byte: binary data, not a text file */
    {
        static const char nul[] = "1 2 3 4 5 6\n1 2 3\0 4 5 6\n1 2 3 4 5 6\n";
        char err[256];
        uint32_t *poses = NULL;
        uint32_t n = 0;
        char prefix[sizeof g_path + 16];
        unsigned joints = 0;
        write_file(nul, sizeof nul - 1u);
        assert_int_equal(replay_file_load(g_path, CPR32, &poses, &n, &joints, err, sizeof err),
                         -1);
        snprintf(prefix, sizeof prefix, "%s:2: a NUL byte", g_path);
        if (strncmp(err, prefix, strlen(prefix)) != 0) {
            fail_msg("error '%s', expected '%s'", err, prefix);
        }
    }
}

/* 4, 5 and 7 joints (issue 26): K from the first pose or the header, the
 * buffer K counts a pose. */
static void test_other_joint_counts(void **state)
{
    static const uint32_t four[] = {1, 2, 3, 4, 5, 6, 7, 8};
    static const uint32_t five[] = {10, 20, 30, 40, 50, 11, 21, 31, 41, 51};
    static const uint32_t seven[] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 4294967295u};
    (void)state;
    expect_poses_k("1 2 3 4\n# four joints\n5,6,7,8\n", CPR32, 4, four, 2);
    expect_poses_k("10 20 30 40 50\r\n\r\n11\t21 31 41 51", CPR32, 5, five, 2);
    expect_poses_k("1 2 3 4 5 6 7 # seven\n8 9 10 11 12 13 4294967295\n", CPR32, 7, seven, 2);
    /* CSV: an aacmm log of a 4-, 5- and 7-joint arm, columns in any order */
    expect_poses_k("seq,device_time_us,count1,count2,count3,count4,flags\n"
                   "1,1000,1,2,3,4,0\n"
                   "2,2000,9,9,9,9,2\n"
                   "3,3000,5,6,7,8,0\n",
                   CPR32, 4, four, 2);
    expect_poses_k("count5,count4,count3,count2,count1,x\n50,40,30,20,10,a\n51,41,31,21,11,b\n",
                   CPR32, 5, five, 2);
    expect_poses_k("seq,count1,count2,count3,count4,count5,count6,count7,flags\r\n"
                   "1,1,2,3,4,5,6,7,0\r\n"
                   "2,8,9,10,11,12,13,4294967295,1\r\n",
                   CPR32, 7, seven, 2);
    /* names that only look like counts are other columns */
    expect_poses_k("counts,count,count1x,count1,count2,count3,count4\n9,9,9,1,2,3,4\n"
                   "9,9,9,5,6,7,8\n",
                   CPR32, 4, four, 2);
}

static void test_joint_count_errors(void **state)
{
    (void)state;
    /* plain: too few on the first pose, then every pose as the first */
    expect_line_error("# three\n1 2 3\n", CPR32, 2, "3 counts (a pose has 4 to 7)");
    expect_line_error("1\n", CPR32, 1, "1 counts (a pose has 4 to 7)");
    expect_line_error("1 2 3 4\n\n5 6 7 8 9\n", CPR32, 3, "more than 4 counts, as on line 1");
    expect_line_error("# c\n1 2 3 4 5\n1 2 3 4\n", CPR32, 3, "4 counts, expected 5 as on line 2");
    expect_line_error("1 2 3 4 5 6 7\n1 2 3 4 5 6\n", CPR32, 2,
                      "6 counts, expected 7 as on line 1");
    expect_line_error("1 2 3 4 5 6 7\n1 2 3 4 5 6 7 8\n", CPR32, 2, "more than 7 counts");
    /* CSV: K of 4..7, consecutive from count1, each once */
    expect_line_error("count1,count2,count3\n1,2,3\n", CPR32, 1, "no column count4");
    expect_line_error("count1,count2,count3,count5\n1,2,3,5\n", CPR32, 1, "no column count4");
    expect_line_error("count2,count3,count4,count5\n1,2,3,5\n", CPR32, 1, "no column count1");
    expect_line_error("count1,count2,count3,count4,count5,count7\n1,2,3,4,5,7\n", CPR32, 1,
                      "no column count6");
    expect_line_error("count1,count2,count3,count4,count5,count6,count7,count8\n"
                      "1,2,3,4,5,6,7,8\n",
                      CPR32, 1, "column 'count8': not a joint of a replay");
    expect_line_error("count0,count1,count2,count3,count4\n0,1,2,3,4\n", CPR32, 1,
                      "column 'count0'");
    expect_line_error("count1,count2,count3,count4,count01\n1,2,3,4,1\n", CPR32, 1,
                      "column 'count01'");
    expect_line_error("count1,count2,count3,count4,count99999999999999999999\n1,2,3,4,5\n",
                      CPR32, 1, "not a joint of a replay");
    expect_line_error("count1,count2,count3,count4,count2\n1,2,3,4,5\n", CPR32, 1,
                      "column count2 twice");
    /* the rows: every one of K columns present and a count */
    expect_line_error("count1,count2,count3,count4,count5,count6,count7\n1,2,3,4,5,6\n", CPR32, 2,
                      "6 fields, the header has more");
    expect_line_error("count1,count2,count3,count4,count5,count6,count7\n1,2,3,4,5,6,nan\n",
                      CPR32, 2, "count7: expected an unsigned count");
    expect_line_error("count1,count2,count3,count4,count5,count6,count7\n"
                      "1,2,3,4,5,6,18446744073709551616\n",
                      CPR32, 2, "count7: expected an unsigned count");
    expect_line_error("count1,count2,count3,count4,count5,count6,count7\n0,0,0,0,0,0,4096\n",
                      4096u, 2, "count7 4096 is not below 4096");
    expect_line_error("1 2 3 4 5 6 4096\n", 4096u, 1, "count 4096 is not below 4096");
    expect_line_error("1 2 3 4\n1 2 3 -4\n", CPR32, 2, "expected an unsigned count");
    expect_error(write_text("count1,count2,count3,count4\n"), CPR32, "no poses");
    expect_error(write_text("count1,count2,count3,count4,count5,flags\n1,2,3,4,5,2\n"), CPR32,
                 "no poses");
    /* a NUL byte and an overlong line in a 4-joint file */
    {
        static const char nul[] = "1 2 3 4\n1 2\0 3 4\n";
        char err[256];
        char prefix[sizeof g_path + 16];
        uint32_t *poses = NULL;
        uint32_t n = 0;
        unsigned k = 0;
        static char text[6000];
        write_file(nul, sizeof nul - 1u);
        assert_int_equal(replay_file_load(g_path, CPR32, &poses, &n, &k, err, sizeof err), -1);
        snprintf(prefix, sizeof prefix, "%s:2: a NUL byte", g_path);
        if (strncmp(err, prefix, strlen(prefix)) != 0) {
            fail_msg("error '%s', expected '%s'", err, prefix);
        }
        memcpy(text, "count1,count2,count3,count4\n", 28);
        memset(text + 28, '0', 5000);
        text[28 + 5000] = '\0';
        expect_line_error(text, CPR32, 2, "line too long");
    }
}

static void test_small_error_buffer(void **state)
{
    char err[8];
    uint32_t *poses = NULL;
    uint32_t n = 0;
    unsigned k = 0;
    (void)state;
    write_text("1 2 3\n");
    assert_int_equal(replay_file_load(g_path, CPR32, &poses, &n, &k, err, sizeof err), -1);
    assert_int_equal(strlen(err), sizeof err - 1u); /* cut, still terminated */
    assert_null(poses);
}

/* POSES poses of k joints through the file: every pose in order, past the
 * first doublings of the buffer. */
static void many_poses(unsigned k)
{
    enum { POSES = 1000 };
    static char text[POSES * 80];
    static uint32_t want[POSES * AACMM_JOINTS_MAX];
    size_t len = 0;
    uint32_t i, j;
    for (i = 0; i < POSES; i++) {
        for (j = 0; j < k; j++) {
            want[i * k + j] = i * 7919u + j * 104729u;
            len += (size_t)sprintf(text + len, j ? ",%u" : "%u", want[i * k + j]);
        }
        text[len++] = '\n';
    }
    text[len] = '\0';
    expect_poses_k(text, CPR32, k, want, POSES);
}

static void test_many_poses(void **state)
{
    unsigned k;
    (void)state;
    for (k = 4; k <= 7; k++) {
        many_poses(k);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_plain_poses),
        cmocka_unit_test(test_csv_poses),
        cmocka_unit_test(test_missing_and_empty),
        cmocka_unit_test(test_malformed_lines),
        cmocka_unit_test(test_nan_inf_exponents),
        cmocka_unit_test(test_huge_values),
        cmocka_unit_test(test_long_lines_columns_nul),
        cmocka_unit_test(test_other_joint_counts),
        cmocka_unit_test(test_joint_count_errors),
        cmocka_unit_test(test_small_error_buffer),
        cmocka_unit_test(test_many_poses),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
