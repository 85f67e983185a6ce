/*
 * Boot check image: prints a banner with the board name and the time base,
 * then echoes every byte received on the UART. Used by tests/boards to check
 * that a port boots, that its UART works both ways and that its clock runs
 * (until the device application replaces it as the board's main image).
 * Two bytes, each alone in a read, ask instead of being echoed: "?" for the
 * time in microseconds, "#" for the UART driver's counters (uart.h).
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "board.h"
#include "uart.h"

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

static void say_u64(uint64_t v)
{
    char digits[20];
    board_uart_write_blocking((const uint8_t *)digits, put_u64(digits, v));
}

/* "rx_bytes=.. rx_pauses=.. rx_errors=.. tx_bytes=.. tx_peak_bytes=..\n",
 * the counters as they were before this line was queued. */
static void say_counts(void)
{
    board_uart_counts_t c;
    board_uart_counts(&c);
    say("rx_bytes=");
    say_u64(c.rx_bytes);
    say(" rx_pauses=");
    say_u64(c.rx_pauses);
    say(" rx_errors=");
    say_u64(c.rx_errors);
    say(" tx_bytes=");
    say_u64(c.tx_bytes);
    say(" tx_peak_bytes=");
    say_u64(c.tx_peak_bytes);
    say("\n");
}

int main(void)
{
    char line[32];
    size_t n;
    board_init();
    say("aacmm boot ");
    say(board_name);
    say(" tick_hz=");
    say_u64(board_tick_hz);
    say(" t_us=");
    say_u64(board_time_us());
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
            } else if (got == 1u && buf[0] == '#') {
                say_counts();
            } else {
                board_uart_write_blocking(buf, got);
            }
        } else {
            board_idle();
        }
    }
}
