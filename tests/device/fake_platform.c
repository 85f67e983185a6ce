#include "fake_platform.h"

#include <string.h>

static uint64_t f_time(void *ctx)
{
    return ((fake_t *)ctx)->now_us;
}

static aacmm_status_t f_serial_read(void *ctx, uint8_t *buf, size_t cap, size_t *got)
{
    fake_t *f = ctx;
    size_t n = f->rx_len - f->rx_pos;
    *got = 0;
    if (f->serial_error) {
        return AACMM_ERR_IO;
    }
    if (n > cap) {
        n = cap;
    }
    memcpy(buf, f->rx + f->rx_pos, n);
    f->rx_pos += n;
    *got = n;
    return AACMM_OK;
}

static aacmm_status_t f_serial_write(void *ctx, const uint8_t *data, size_t len, size_t *accepted)
{
    fake_t *f = ctx;
    size_t n = len;
    *accepted = 0;
    if (f->serial_error) {
        return AACMM_ERR_IO;
    }
    if (n > f->tx_limit) {
        n = f->tx_limit;
    }
    if (n > FAKE_SERIAL_TX - f->tx_len) {
        n = FAKE_SERIAL_TX - f->tx_len;
    }
    memcpy(f->tx + f->tx_len, data, n);
    f->tx_len += n;
    *accepted = n;
    return AACMM_OK;
}

static aacmm_status_t f_can_send(void *ctx, const aacmm_can_frame_t *frame)
{
    fake_t *f = ctx;
    if (f->can_busy || f->can_tx_len == FAKE_CAN_TX) {
        return AACMM_ERR_BUSY;
    }
    f->can_tx[f->can_tx_len++] = *frame;
    return AACMM_OK;
}

static aacmm_status_t f_can_receive(void *ctx, aacmm_can_frame_t *frame, int *got)
{
    fake_t *f = ctx;
    *got = 0;
    if (f->can_rx_pos < f->can_rx_len) {
        *frame = f->can_rx[f->can_rx_pos++];
        *got = 1;
    }
    return AACMM_OK;
}

static aacmm_status_t f_read_encoders(void *ctx, uint32_t counts[AACMM_JOINTS_MAX])
{
    fake_t *f = ctx;
    f->encoder_reads++;
    if (f->encoder_status != AACMM_OK) {
        return f->encoder_status;
    }
    memcpy(counts, f->counts, sizeof f->counts);
    return AACMM_OK;
}

static aacmm_status_t f_read_encoder_frames(void *ctx, aacmm_enc_frame_t frames[AACMM_JOINTS_MAX])
{
    fake_t *f = ctx;
    f->encoder_reads++;
    if (f->encoder_status != AACMM_OK) {
        return f->encoder_status;
    }
    memcpy(frames, f->frames, sizeof f->frames);
    return AACMM_OK;
}

static aacmm_status_t f_read_buttons(void *ctx, uint8_t *pressed)
{
    *pressed = ((fake_t *)ctx)->button;
    return AACMM_OK;
}

static aacmm_status_t f_read_temperatures(void *ctx, int16_t temp[AACMM_JOINTS_MAX],
                                          uint8_t *valid)
{
    fake_t *f = ctx;
    f->temp_reads++;
    if (f->temp_status != AACMM_OK) {
        return f->temp_status;
    }
    memcpy(temp, f->temp, sizeof f->temp);
    *valid = f->temp_valid;
    return AACMM_OK;
}

static aacmm_status_t f_storage_read(void *ctx, uint32_t offset, uint8_t *buf, size_t len)
{
    fake_t *f = ctx;
    if (f->read_error || (size_t)offset + len > sizeof f->storage) {
        return AACMM_ERR_IO;
    }
    memcpy(buf, f->storage + offset, len);
    return AACMM_OK;
}

static aacmm_status_t f_storage_write(void *ctx, uint32_t offset, const uint8_t *data, size_t len)
{
    fake_t *f = ctx;
    size_t i;
    if ((size_t)offset + len > sizeof f->storage) {
        return AACMM_ERR_IO;
    }
    f->storage_writes++;
    for (i = 0; i < len; i++) {
        if (f->write_budget == 0) {
            return AACMM_ERR_IO; /* power cut: the rest never reaches the medium */
        }
        if (f->write_budget > 0) {
            f->write_budget--;
        }
        if (f->flash) {
            f->storage[offset + i] &= data[i]; /* programming only clears bits */
        } else {
            f->storage[offset + i] = data[i];
        }
    }
    return AACMM_OK;
}

static aacmm_status_t f_storage_erase(void *ctx, uint32_t offset, size_t len)
{
    fake_t *f = ctx;
    size_t i;
    if ((size_t)offset + len > sizeof f->storage) {
        return AACMM_ERR_IO;
    }
    f->storage_erases++;
    for (i = 0; i < len; i++) {
        if (f->write_budget == 0) {
            return AACMM_ERR_IO; /* power cut in the middle of the erase */
        }
        if (f->write_budget > 0) {
            f->write_budget--;
        }
        f->storage[offset + i] = 0xFFu;
    }
    return AACMM_OK;
}

void fake_use_frames(fake_t *f, aacmm_platform_t *pf)
{
    (void)f;
    pf->read_encoder_frames = f_read_encoder_frames;
}

void fake_use_temperatures(fake_t *f, aacmm_platform_t *pf)
{
    int i;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        f->temp[i] = 2000;
    }
    f->temp_valid = 0x7Fu;
    f->temp_status = AACMM_OK;
    pf->read_temperatures = f_read_temperatures;
}

void fake_use_flash(fake_t *f, aacmm_platform_t *pf)
{
    f->flash = 1;
    pf->storage_erase = f_storage_erase;
}

void fake_init(fake_t *f)
{
    memset(f, 0, sizeof *f);
    f->now_us = 1000000u;
    f->tx_limit = (size_t)-1;
    f->encoder_status = AACMM_OK;
    f->write_budget = -1;
    memset(f->storage, 0xFF, sizeof f->storage);
}

void fake_platform(fake_t *f, aacmm_platform_t *pf, int serial, int can, int storage, int button)
{
    memset(pf, 0, sizeof *pf);
    pf->ctx = f;
    pf->time_us = f_time;
    if (serial) {
        pf->serial_read = f_serial_read;
        pf->serial_write = f_serial_write;
    }
    if (can) {
        pf->can_send = f_can_send;
        pf->can_receive = f_can_receive;
    }
    pf->read_encoders = f_read_encoders;
    if (button) {
        pf->read_buttons = f_read_buttons;
    }
    if (storage) {
        pf->storage_read = f_storage_read;
        pf->storage_write = f_storage_write;
        pf->storage_bytes = AACMM_STORE_BYTES;
    }
}
