#include "proto.h"

#include "cobs.h"
#include "crc16.h"

/* Multi-byte fields are little endian, like the AVR, so packing is a plain byte walk. */
static uint8_t *put16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    return p + 2;
}

static uint8_t *put32(uint8_t *p, uint32_t v)
{
    p = put16(p, (uint16_t)v);
    return put16(p, (uint16_t)(v >> 16));
}

int proto_payload_len(uint8_t type)
{
    switch (type) {
    case PROTO_HELLO: return PROTO_HELLO_LEN;
    case PROTO_HEARTBEAT: return PROTO_HEARTBEAT_LEN;
    case PROTO_AXES: return PROTO_AXES_LEN;
    case PROTO_CALIBRATION: return PROTO_CALIBRATION_LEN;
    case PROTO_HELLO_REQUEST: return 0;
    case PROTO_CALIBRATE: return 0;
    case PROTO_WATCHDOG_TEST: return PROTO_WATCHDOG_TEST_LEN;
    default: return -1;
    }
}

size_t proto_pack_hello(uint8_t *out, const struct proto_hello *m)
{
    uint8_t *p = out;
    *p++ = m->fw_major;
    *p++ = m->fw_minor;
    *p++ = m->fw_patch;
    *p++ = m->board;
    *p++ = m->n_axes;
    *p++ = m->n_buttons;
    *p++ = m->frame_hz;
    p = put16(p, m->heartbeat_ms);
    *p++ = m->reset_cause;
    return (size_t)(p - out);
}

size_t proto_pack_heartbeat(uint8_t *out, const struct proto_heartbeat *m)
{
    uint8_t *p = put32(out, m->uptime_ms);
    p = put16(p, m->rx_ok);
    p = put16(p, m->rx_rejected);
    return (size_t)(p - out);
}

size_t proto_pack_axes(uint8_t *out, const struct proto_axes *m)
{
    uint8_t *p = put16(out, m->t_ms);
    for (int i = 0; i < PROTO_AXES_N; i++)
        p = put16(p, (uint16_t)m->axis[i]);
    *p++ = m->buttons;
    return (size_t)(p - out);
}

size_t proto_pack_calibration(uint8_t *out, const struct proto_calibration *m)
{
    uint8_t *p = out;
    *p++ = m->reason;
    *p++ = m->eeprom_mask;
    for (int i = 0; i < PROTO_AXES_N; i++)
        p = put16(p, m->zero[i]);
    return (size_t)(p - out);
}

size_t proto_frame(uint8_t type, uint8_t seq, const uint8_t *payload, size_t len, uint8_t *out)
{
    uint8_t raw[PROTO_MAX_RAW];

    if (len > PROTO_MAX_PAYLOAD)
        return 0;
    raw[0] = PROTO_VERSION;
    raw[1] = type;
    raw[2] = seq;
    for (size_t i = 0; i < len; i++)
        raw[PROTO_HEADER + i] = payload[i];
    put16(raw + PROTO_HEADER + len, crc16_ccitt(raw, PROTO_HEADER + len));

    size_t n = cobs_encode(raw, PROTO_HEADER + len + PROTO_CRC, out);
    out[n++] = 0x00;
    return n;
}

enum proto_reject proto_parse(const uint8_t *chunk, size_t len, struct proto_msg *msg)
{
    uint8_t raw[PROTO_MAX_RAW];

    if (len > PROTO_MAX_ENCODED)
        return PROTO_REJ_TOO_LONG;
    int n = cobs_decode(chunk, len, raw, sizeof raw);
    if (n < 0)
        return PROTO_REJ_COBS;
    if (n < PROTO_HEADER + PROTO_CRC)
        return PROTO_REJ_SHORT;
    /* CRC first: a corrupt frame must not be reported as a version or type problem. */
    uint16_t crc = (uint16_t)(raw[n - 2] | (raw[n - 1] << 8));
    if (crc16_ccitt(raw, (size_t)n - PROTO_CRC) != crc)
        return PROTO_REJ_CRC;
    if (raw[0] != PROTO_VERSION)
        return PROTO_REJ_VERSION;
    int want = proto_payload_len(raw[1]);
    if (want < 0)
        return PROTO_REJ_TYPE;
    if (n - PROTO_HEADER - PROTO_CRC != want)
        return PROTO_REJ_LENGTH;

    msg->type = raw[1];
    msg->seq = raw[2];
    msg->len = (uint8_t)want;
    for (int i = 0; i < want; i++)
        msg->payload[i] = raw[PROTO_HEADER + i];
    return PROTO_OK;
}

void proto_rx_init(struct proto_rx *rx)
{
    rx->len = 0;
    rx->overflow = 0;
    rx->overflow_n = 0;
    rx->last_reject = PROTO_OK;
    rx->frames_ok = 0;
    rx->rejected = 0;
    rx->bytes_skipped = 0;
}

int proto_rx_byte(struct proto_rx *rx, uint8_t byte, struct proto_msg *msg)
{
    if (byte != 0x00) {
        if (rx->len < sizeof rx->buf) {
            rx->buf[rx->len++] = byte;
        } else {
            rx->overflow = 1;
            rx->overflow_n++;
        }
        return 0;
    }

    enum proto_reject why;
    uint32_t n = rx->len + rx->overflow_n;
    if (n == 0)
        return 0; /* back-to-back delimiters are idle fill, not errors */
    why = rx->overflow ? PROTO_REJ_TOO_LONG : proto_parse(rx->buf, rx->len, msg);
    rx->len = 0;
    rx->overflow = 0;
    rx->overflow_n = 0;
    rx->last_reject = (uint8_t)why;
    if (why == PROTO_OK) {
        rx->frames_ok++;
        return 1;
    }
    rx->rejected++;
    rx->bytes_skipped += n;
    return 0;
}
