#include "aacmm/isotp.h"

#include <string.h>

enum { RX_IDLE = 0, RX_BUSY = 1, RX_READY = 2 };
enum { TX_IDLE = 0, TX_START = 1, TX_WAIT_FC = 2, TX_SENDING = 3 };
enum { PCI_SF = 0, PCI_FF = 1, PCI_CF = 2, PCI_FC = 3 };
enum { FS_CTS = 0, FS_WAIT = 1, FS_OVFLW = 2 };

/* a is at or after b on the wrapping millisecond clock */
static int time_reached(uint32_t now, uint32_t deadline)
{
    return (uint32_t)(now - deadline) < 0x80000000u;
}

aacmm_status_t aacmm_isotp_init(aacmm_isotp_t *tp, const aacmm_isotp_config_t *cfg)
{
    if (tp == NULL || cfg == NULL || cfg->rx_buf == NULL || cfg->tx_buf == NULL) {
        return AACMM_ERR_NULL;
    }
    if (cfg->tx_id > 0x7FFu || cfg->rx_id > 0x7FFu || cfg->tx_id == cfg->rx_id ||
        cfg->rx_cap == 0u || cfg->rx_cap > AACMM_ISOTP_MAX_LEN || cfg->tx_cap == 0u ||
        cfg->tx_cap > AACMM_ISOTP_MAX_LEN || cfg->timeout_ms == 0u ||
        cfg->timeout_ms >= 0x80000000u) {
        return AACMM_ERR_RANGE;
    }
    memset(tp, 0, sizeof *tp);
    tp->cfg = *cfg;
    tp->tx_result = AACMM_OK;
    return AACMM_OK;
}

static void rx_abort(aacmm_isotp_t *tp)
{
    tp->rx_state = RX_IDLE;
    tp->rx_len = 0u;
    tp->rx_pos = 0u;
}

static void tx_finish(aacmm_isotp_t *tp, aacmm_status_t result)
{
    tp->tx_state = TX_IDLE;
    tp->tx_result = result;
}

static uint32_t stmin_to_ms(uint8_t raw)
{
    if (raw <= 0x7Fu) {
        return raw;
    }
    if (raw >= 0xF1u && raw <= 0xF9u) {
        return 1u; /* 100..900 us, rounded up to the clock resolution */
    }
    return 0x7Fu; /* reserved values: use the largest defined STmin */
}

static void on_flow_control(aacmm_isotp_t *tp, const aacmm_can_frame_t *f, uint32_t now_ms)
{
    uint8_t fs;
    if (tp->tx_state != TX_WAIT_FC) {
        tp->stats.rx_unexpected++;
        return;
    }
    if (f->dlc < 3u) {
        tp->stats.rx_bad_frames++;
        return;
    }
    fs = (uint8_t)(f->data[0] & 0x0Fu);
    if (fs == FS_CTS) {
        tp->tx_bs = f->data[1];
        tp->tx_block = 0u;
        tp->tx_waits = 0u;
        tp->tx_stmin_ms = stmin_to_ms(f->data[2]);
        tp->tx_state = TX_SENDING;
        tp->tx_next_ms = now_ms;
    } else if (fs == FS_WAIT) {
        tp->tx_waits++;
        if (tp->tx_waits > tp->cfg.max_wait) {
            tp->stats.tx_aborted++;
            tx_finish(tp, AACMM_ERR_FRAME);
        } else {
            tp->tx_deadline_ms = now_ms + tp->cfg.timeout_ms;
        }
    } else if (fs == FS_OVFLW) {
        tp->stats.tx_refused++;
        tx_finish(tp, AACMM_ERR_OVERFLOW);
    } else {
        tp->stats.tx_aborted++;
        tx_finish(tp, AACMM_ERR_FRAME);
    }
}

static void start_reception(aacmm_isotp_t *tp)
{
    if (tp->rx_state == RX_BUSY) {
        tp->stats.rx_interrupted++;
    }
    rx_abort(tp);
}

void aacmm_isotp_on_frame(aacmm_isotp_t *tp, const aacmm_can_frame_t *f, uint32_t now_ms)
{
    uint8_t pci;
    size_t n;
    if (tp == NULL || f == NULL || f->id != tp->cfg.rx_id) {
        return;
    }
    if (f->dlc == 0u || f->dlc > AACMM_CAN_MAX_DLC) {
        tp->stats.rx_bad_frames++;
        return;
    }
    pci = (uint8_t)(f->data[0] >> 4);
    switch (pci) {
    case PCI_SF:
        n = (size_t)(f->data[0] & 0x0Fu);
        if (n == 0u || n > 7u || n + 1u > f->dlc) {
            tp->stats.rx_bad_frames++;
            return;
        }
        start_reception(tp);
        if (n > tp->cfg.rx_cap) {
            tp->stats.rx_overflows++;
            return;
        }
        memcpy(tp->cfg.rx_buf, &f->data[1], n);
        tp->rx_len = n;
        tp->rx_pos = n;
        tp->rx_state = RX_READY;
        tp->stats.rx_messages++;
        return;
    case PCI_FF:
        n = ((size_t)(f->data[0] & 0x0Fu) << 8) | (size_t)f->data[1];
        if (f->dlc < 8u || n < 8u) {
            tp->stats.rx_bad_frames++;
            return;
        }
        start_reception(tp);
        if (n > tp->cfg.rx_cap) {
            tp->stats.rx_overflows++;
            tp->fc_pending = (uint8_t)(FS_OVFLW + 1);
            return;
        }
        memcpy(tp->cfg.rx_buf, &f->data[2], 6u);
        tp->rx_len = n;
        tp->rx_pos = 6u;
        tp->rx_sn = 1u;
        tp->rx_block = 0u;
        tp->rx_state = RX_BUSY;
        tp->rx_deadline_ms = now_ms + tp->cfg.timeout_ms;
        tp->fc_pending = (uint8_t)(FS_CTS + 1);
        return;
    case PCI_CF: {
        size_t left;
        if (tp->rx_state != RX_BUSY) {
            tp->stats.rx_unexpected++;
            return;
        }
        if ((f->data[0] & 0x0Fu) != tp->rx_sn) {
            tp->stats.rx_sequence_errors++;
            rx_abort(tp);
            return;
        }
        left = tp->rx_len - tp->rx_pos;
        n = left < 7u ? left : 7u;
        if ((size_t)f->dlc < n + 1u) {
            tp->stats.rx_bad_frames++;
            rx_abort(tp);
            return;
        }
        memcpy(tp->cfg.rx_buf + tp->rx_pos, &f->data[1], n);
        tp->rx_pos += n;
        tp->rx_sn = (uint8_t)((tp->rx_sn + 1u) & 0x0Fu);
        tp->rx_deadline_ms = now_ms + tp->cfg.timeout_ms;
        if (tp->rx_pos >= tp->rx_len) {
            tp->rx_state = RX_READY;
            tp->stats.rx_messages++;
            return;
        }
        if (tp->cfg.block_size != 0u) {
            tp->rx_block++;
            if (tp->rx_block >= tp->cfg.block_size) {
                tp->rx_block = 0u;
                tp->fc_pending = (uint8_t)(FS_CTS + 1);
            }
        }
        return;
    }
    case PCI_FC:
        on_flow_control(tp, f, now_ms);
        return;
    default:
        tp->stats.rx_bad_frames++;
        return;
    }
}

int aacmm_isotp_receive(aacmm_isotp_t *tp, const uint8_t **data, size_t *len)
{
    if (tp == NULL || data == NULL || len == NULL || tp->rx_state != RX_READY) {
        return 0;
    }
    *data = tp->cfg.rx_buf;
    *len = tp->rx_len;
    tp->rx_state = RX_IDLE;
    return 1;
}

aacmm_status_t aacmm_isotp_send(aacmm_isotp_t *tp, const uint8_t *data, size_t len,
                                uint32_t now_ms)
{
    if (tp == NULL || data == NULL) {
        return AACMM_ERR_NULL;
    }
    if (tp->tx_state != TX_IDLE) {
        return AACMM_ERR_BUSY;
    }
    if (len == 0u || len > tp->cfg.tx_cap || len > AACMM_ISOTP_MAX_LEN) {
        return AACMM_ERR_LENGTH;
    }
    memcpy(tp->cfg.tx_buf, data, len);
    tp->tx_len = len;
    tp->tx_pos = 0u;
    tp->tx_state = TX_START;
    tp->tx_result = AACMM_ERR_BUSY;
    tp->tx_next_ms = now_ms;
    return AACMM_OK;
}

static void frame_begin(const aacmm_isotp_t *tp, aacmm_can_frame_t *out)
{
    out->id = tp->cfg.tx_id;
    out->dlc = 8u;
    memset(out->data, tp->cfg.padding, sizeof out->data);
}

int aacmm_isotp_poll(aacmm_isotp_t *tp, uint32_t now_ms, aacmm_can_frame_t *out)
{
    if (tp == NULL || out == NULL) {
        return 0;
    }
    /* timeouts */
    if (tp->rx_state == RX_BUSY && time_reached(now_ms, tp->rx_deadline_ms)) {
        tp->stats.rx_timeouts++;
        rx_abort(tp);
        tp->fc_pending = 0u;
    }
    if (tp->tx_state == TX_WAIT_FC && time_reached(now_ms, tp->tx_deadline_ms)) {
        tp->stats.tx_timeouts++;
        tx_finish(tp, AACMM_ERR_TIMEOUT);
    }
    /* flow control for our reception first */
    if (tp->fc_pending != 0u) {
        frame_begin(tp, out);
        out->data[0] = (uint8_t)(0x30u | (uint8_t)(tp->fc_pending - 1u));
        out->data[1] = tp->cfg.block_size;
        out->data[2] = tp->cfg.st_min;
        tp->fc_pending = 0u;
        return 1;
    }
    if (tp->tx_state == TX_START) {
        frame_begin(tp, out);
        if (tp->tx_len <= 7u) {
            out->data[0] = (uint8_t)tp->tx_len;
            memcpy(&out->data[1], tp->cfg.tx_buf, tp->tx_len);
            tp->stats.tx_messages++;
            tx_finish(tp, AACMM_OK);
            return 1;
        }
        out->data[0] = (uint8_t)(0x10u | (uint8_t)((tp->tx_len >> 8) & 0x0Fu));
        out->data[1] = (uint8_t)(tp->tx_len & 0xFFu);
        memcpy(&out->data[2], tp->cfg.tx_buf, 6u);
        tp->tx_pos = 6u;
        tp->tx_sn = 1u;
        tp->tx_waits = 0u;
        tp->tx_state = TX_WAIT_FC;
        tp->tx_deadline_ms = now_ms + tp->cfg.timeout_ms;
        return 1;
    }
    if (tp->tx_state == TX_SENDING && time_reached(now_ms, tp->tx_next_ms)) {
        size_t left = tp->tx_len - tp->tx_pos;
        size_t n = left < 7u ? left : 7u;
        frame_begin(tp, out);
        out->data[0] = (uint8_t)(0x20u | tp->tx_sn);
        memcpy(&out->data[1], tp->cfg.tx_buf + tp->tx_pos, n);
        tp->tx_pos += n;
        tp->tx_sn = (uint8_t)((tp->tx_sn + 1u) & 0x0Fu);
        /* STmin is a minimum: with a 1 ms clock, wait one extra tick. */
        tp->tx_next_ms = now_ms + (tp->tx_stmin_ms != 0u ? tp->tx_stmin_ms + 1u : 0u);
        if (tp->tx_pos >= tp->tx_len) {
            tp->stats.tx_messages++;
            tx_finish(tp, AACMM_OK);
            return 1;
        }
        if (tp->tx_bs != 0u) {
            tp->tx_block++;
            if (tp->tx_block >= tp->tx_bs) {
                tp->tx_state = TX_WAIT_FC;
                tp->tx_deadline_ms = now_ms + tp->cfg.timeout_ms;
            }
        }
        return 1;
    }
    return 0;
}

aacmm_status_t aacmm_isotp_tx_result(const aacmm_isotp_t *tp)
{
    if (tp == NULL) {
        return AACMM_ERR_NULL;
    }
    return tp->tx_result;
}
