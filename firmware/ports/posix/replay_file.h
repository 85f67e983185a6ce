/*
 * Replay files for aacmm-sim's --motion replay:FILE (docs/simulator.md): the
 * joint counts the simulated arm steps through, one pose per sample. Part of
 * the POSIX port (it uses stdio and the heap, which the portable core does
 * not); the file is untrusted input.
 *
 * A pose is K raw encoder counts (units: counts, 0 .. cpr - 1), joints
 * 1..K of an arm of K = AACMM_JOINTS_MIN .. AACMM_JOINTS_MAX (4 .. 7)
 * joints; every pose of a file has the same K.
 *
 * Two formats, told apart by the first line:
 *   - plain: one pose per line, K unsigned decimal counts separated by blanks
 *     or commas; the first pose line sets K (4..7), every other pose line has
 *     as many (else an error naming the line and the first pose's line); '#'
 *     starts a comment; blank and comment-only lines are skipped;
 *   - CSV: the first line starts with a letter and is a header naming the
 *     columns count1..countK, K = 4..7, every one of them once, in any order
 *     (an `aacmm log` or trigger file of a K-joint arm); a gap (count1..3 and
 *     count5), a column count0, count8 or beyond, or a column named twice is
 *     an error; other columns are ignored, a `flags` column's rows with
 *     ENCODER_FAULT (bit 1) are skipped. Fields are split at commas (no
 *     quoting: aacmm's files have none).
 * Both accept LF or CRLF line ends and a last line without one.
 *
 * Limits: a line of at most 4095 bytes with its end, at most 64 CSV
 * columns, at most UINT32_MAX / K poses; every count below cpr (which is
 * 2 .. 2^32, so a count fits 32 bits). A number is decimal digits only: a
 * sign, a fraction, an exponent, "nan" or "inf", a value that overflows 64
 * bits or one at or above cpr is refused, as is a NUL byte.
 */
#ifndef AACMM_REPLAY_FILE_H
#define AACMM_REPLAY_FILE_H

#include <stddef.h>
#include <stdint.h>

#include "aacmm/kinematics.h"

/*
 * Read the replay file at path. On success returns 0 with *joints = K
 * (4..7) and *poses pointing to *n * K counts (pose i's joint j, j = 0..K-1,
 * at [K * i + j]), *n >= 1, in a buffer from malloc that the caller frees
 * with free(). Otherwise returns -1, leaves *poses, *n and *joints
 * untouched, allocates nothing, and writes one line without a newline into
 * err (at most err_cap bytes, err_cap > 0): "PATH:LINE: problem" for a line
 * that is wrong (LINE counts from 1), "PATH: no poses ..." for a file
 * without any, "cannot open replay file PATH: reason" or "cannot read ...".
 * The file is read once, front to back; cost O(file size), memory 4 * K
 * bytes per pose (the buffer doubles as it grows, so at most twice that).
 */
int replay_file_load(const char *path, uint64_t cpr, uint32_t **poses, uint32_t *n,
                     unsigned *joints, char *err, size_t err_cap);

#endif /* AACMM_REPLAY_FILE_H */
