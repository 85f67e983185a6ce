/*
 * Boot check image: prints a banner with the board name and the time base,
 * then echoes every byte received on the UART. Used by tests/boards to check
 * that a port boots, that its UART works both ways and that its clock runs
 * (until the device application replaces it as the board's main image).
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "board.h"

static size_t put_u64(char *out, uint64_t v)
{
    char tmp[20];
    size_t n = 0, i;
    do {
        tmp[n++] = (char)('0' + (int)(v % 10u));
        v /= 10u;
    } while (v != 0u);
    for (i = 0; i < n; i++) {
        out[i] = tmp[n - 1u - i];
    }
    return n;
}

static void say(const char *s)
{
    board_uart_write_blocking((const uint8_t *)s, strlen(s));
}

int main(void)
{
    char line[32];
    size_t n;
    board_init();
    say("aacmm boot ");
    say(board_name);
    say(" tick_hz=");
    n = put_u64(line, board_tick_hz);
    board_uart_write_blocking((const uint8_t *)line, n);
    say(" t_us=");
    n = put_u64(line, board_time_us());
    board_uart_write_blocking((const uint8_t *)line, n);
    say("\r\n");
    for (;;) {
        uint8_t buf[64];
        size_t got = board_uart_read(buf, sizeof buf);
        if (got > 0u) {
            /* "?" asks for the time: lets the host check that it advances. */
            if (got == 1u && buf[0] == '?') {
                n = put_u64(line, board_time_us());
                line[n++] = '\n';
                board_uart_write_blocking((const uint8_t *)line, n);
            } else {
                board_uart_write_blocking(buf, got);
            }
        } else {
            board_idle();
        }
    }
}
