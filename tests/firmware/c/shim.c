/* Flat entry points into firmware/common for ctypes: the tests call the firmware's own C code,
 * compiled by the host gcc. State structs are handled as opaque buffers sized by *_size(). */
#include <string.h>

#include "axis.h"
#include "calib.h"
#include "cobs.h"
#include "crc16.h"
#include "debounce.h"
#include "knob_report.h"
#include "proto.h"
#include "quad.h"
#include "sched.h"

const uint8_t shim_hid_descriptor[] = { KNOB_HID_DESCRIPTOR_BYTES };
const size_t shim_hid_descriptor_len = sizeof shim_hid_descriptor;

/* Constants the Python side must agree with. */
long shim_const(const char *name)
{
    static const struct { const char *name; long value; } table[] = {
        { "PROTO_VERSION", PROTO_VERSION },
        { "PROTO_MAX_PAYLOAD", PROTO_MAX_PAYLOAD },
        { "PROTO_MAX_ENCODED", PROTO_MAX_ENCODED },
        { "PROTO_AXIS_FULL", PROTO_AXIS_FULL },
        { "PROTO_HELLO_LEN", PROTO_HELLO_LEN },
        { "PROTO_HEARTBEAT_LEN", PROTO_HEARTBEAT_LEN },
        { "PROTO_AXES_LEN", PROTO_AXES_LEN },
        { "PROTO_CALIBRATION_LEN", PROTO_CALIBRATION_LEN },
        { "PROTO_WATCHDOG_TEST_LEN", PROTO_WATCHDOG_TEST_LEN },
        { "KNOB_REPORT_SIZE", KNOB_REPORT_SIZE },
        { "KNOB_REPORT_ID", KNOB_REPORT_ID },
        { "CALIB_RECORD_SIZE", CALIB_RECORD_SIZE },
        { "AXIS_C16_MAX", AXIS_C16_MAX },
    };
    for (size_t i = 0; i < sizeof table / sizeof table[0]; i++)
        if (!strcmp(table[i].name, name))
            return table[i].value;
    return -1;
}

/* Packs a payload from a flat list of field values in struct order (arrays expanded). */
long shim_pack(uint8_t type, const long *f, uint8_t *out)
{
    switch (type) {
    case PROTO_HELLO: {
        struct proto_hello m = { (uint8_t)f[0], (uint8_t)f[1], (uint8_t)f[2], (uint8_t)f[3],
                                 (uint8_t)f[4], (uint8_t)f[5], (uint8_t)f[6], (uint16_t)f[7],
                                 (uint8_t)f[8] };
        return (long)proto_pack_hello(out, &m);
    }
    case PROTO_HEARTBEAT: {
        struct proto_heartbeat m = { (uint32_t)f[0], (uint16_t)f[1], (uint16_t)f[2] };
        return (long)proto_pack_heartbeat(out, &m);
    }
    case PROTO_AXES: {
        struct proto_axes m;
        m.t_ms = (uint16_t)f[0];
        for (int i = 0; i < PROTO_AXES_N; i++)
            m.axis[i] = (int16_t)f[1 + i];
        m.buttons = (uint8_t)f[7];
        return (long)proto_pack_axes(out, &m);
    }
    case PROTO_CALIBRATION: {
        struct proto_calibration m;
        m.reason = (uint8_t)f[0];
        m.eeprom_mask = (uint8_t)f[1];
        for (int i = 0; i < PROTO_AXES_N; i++)
            m.zero[i] = (uint16_t)f[2 + i];
        return (long)proto_pack_calibration(out, &m);
    }
    default:
        return -1;
    }
}

/* proto_parse; out = type, seq, len, payload. Returns the enum proto_reject code. */
int shim_parse(const uint8_t *chunk, size_t len, uint8_t *out)
{
    struct proto_msg m;
    enum proto_reject r = proto_parse(chunk, len, &m);
    if (r == PROTO_OK) {
        out[0] = m.type;
        out[1] = m.seq;
        out[2] = m.len;
        memcpy(out + 3, m.payload, m.len);
    }
    return (int)r;
}

/* Runs the firmware receiver over a byte stream. Each completed chunk appends a record to out:
 * code (0 = frame, else enum proto_reject), type, seq, len, payload[len]. stats gets frames_ok,
 * rejected, bytes_skipped. Returns the bytes written to out, or -1 if cap is too small. */
long shim_rx_stream(const uint8_t *data, size_t n, uint8_t *out, size_t cap, uint32_t *stats)
{
    struct proto_rx rx;
    struct proto_msg m;
    size_t w = 0;

    proto_rx_init(&rx);
    for (size_t i = 0; i < n; i++) {
        uint16_t rejected = rx.rejected;
        if (proto_rx_byte(&rx, data[i], &m)) {
            if (w + 4 + m.len > cap)
                return -1;
            out[w++] = 0;
            out[w++] = m.type;
            out[w++] = m.seq;
            out[w++] = m.len;
            memcpy(out + w, m.payload, m.len);
            w += m.len;
        } else if (rx.rejected != rejected) {
            if (w + 4 > cap)
                return -1;
            out[w++] = rx.last_reject;
            out[w++] = 0;
            out[w++] = 0;
            out[w++] = 0;
        }
    }
    stats[0] = rx.frames_ok;
    stats[1] = rx.rejected;
    stats[2] = rx.bytes_skipped;
    return (long)w;
}

void shim_filter_run(uint8_t shift, const uint16_t *x, size_t n, uint16_t *y)
{
    struct axis_filter f;
    axis_filter_init(&f, shift);
    for (size_t i = 0; i < n; i++)
        y[i] = axis_filter_step(&f, x[i]);
}

int shim_axis_scale(uint16_t value, uint16_t zero, uint16_t deadzone, uint16_t edge)
{
    struct axis_cfg cfg = { deadzone, edge };
    return axis_scale(value, zero, &cfg);
}

void shim_gesture_run(const uint8_t *buttons, size_t n, uint8_t mask, uint16_t hold, uint8_t *fired)
{
    struct calib_gesture g;
    calib_gesture_init(&g);
    for (size_t i = 0; i < n; i++)
        fired[i] = (uint8_t)calib_gesture_step(&g, buttons[i], mask, hold);
}

void shim_debounce_run(uint8_t samples, uint8_t initial, const uint8_t *raw, size_t n, uint8_t *out)
{
    struct debounce d;
    debounce_init(&d, samples, initial);
    for (size_t i = 0; i < n; i++)
        out[i] = debounce_step(&d, raw[i]);
}

void shim_sched_run(uint16_t linger, uint16_t hb, const uint8_t *active, size_t n, uint8_t *out)
{
    struct sched s;
    sched_init(&s, linger, hb);
    for (size_t i = 0; i < n; i++)
        out[i] = (uint8_t)sched_tick(&s, active[i]);
}

/* Feeds AB samples to one decoder whose detent counter starts at `start`. Per sample: the
 * detent step returned; at the end, the counter and the invalid-transition count. */
void shim_quad_run(uint8_t ab0, uint8_t steps, uint8_t start, const uint8_t *ab, size_t n,
                   int8_t *detents, uint8_t *count, uint16_t *errors)
{
    struct quad q;
    quad_init(&q, ab0, steps);
    q.count = start;
    for (size_t i = 0; i < n; i++)
        detents[i] = quad_update(&q, ab[i]);
    *count = q.count;
    *errors = q.errors;
}

size_t shim_knob_report_size(void)
{
    return sizeof(struct knob_report);
}
