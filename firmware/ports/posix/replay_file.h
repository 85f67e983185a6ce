/*
 * Replay files for aacmm-sim's --motion replay:FILE (docs/simulator.md): the
 * joint counts the simulated arm steps through, one pose per sample. Part of
 * the POSIX port (it uses stdio and the heap, which the portable core does
 * not); the file is untrusted input.
 *
 * Two formats, told apart by the first line:
 *   - plain: one pose per line, AACMM_JOINTS (6) unsigned decimal counts
 *     separated by blanks or commas; '#' starts a comment; blank and
 *     comment-only lines are skipped;
 *   - CSV: the first line starts with a letter and is a header naming the
 *     columns count1..count6 (an `aacmm log` or trigger file); other columns
 *     are ignored, a `flags` column's rows with ENCODER_FAULT (bit 1) are
 *     skipped. Fields are split at commas (no quoting: aacmm's files have none).
 * Both accept LF or CRLF line ends and a last line without one.
 *
 * Limits: a line of at most 4095 bytes with its end, at most 64 CSV
 * columns, at most UINT32_MAX / AACMM_JOINTS poses; every count below cpr
 * (which is 2 .. 2^32, so a count fits 32 bits). A number is decimal digits
 * only: a sign, a fraction, an exponent, "nan" or "inf", a value that
 * overflows 64 bits or one at or above cpr is refused, as is a NUL byte.
 */
#ifndef AACMM_REPLAY_FILE_H
#define AACMM_REPLAY_FILE_H

#include <stddef.h>
#include <stdint.h>

#include "aacmm/kinematics.h"

/*
 * Read the replay file at path. On success returns 0 with *poses pointing
 * to *n * AACMM_JOINTS counts (pose i's joint j at [AACMM_JOINTS * i + j]),
 * *n >= 1, in a buffer
 * from malloc that the caller frees with free(). Otherwise returns -1, leaves
 * *poses and *n untouched, allocates nothing, and writes one line without a
 * newline into err (at most err_cap bytes, err_cap > 0): "PATH:LINE: problem"
 * for a line that is wrong (LINE counts from 1), "PATH: no poses ..." for a
 * file without any, "cannot open replay file PATH: reason" or "cannot read
 * ...". The file is read once, front to back; cost O(file size), memory
 * 4 * AACMM_JOINTS bytes per pose (the buffer doubles as it grows).
 */
int replay_file_load(const char *path, uint64_t cpr, uint32_t **poses, uint32_t *n, char *err,
                     size_t err_cap);

#endif /* AACMM_REPLAY_FILE_H */
