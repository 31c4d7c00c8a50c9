#include "calib.h"

#include "axis.h"
#include "crc16.h"

void calib_pack(const uint16_t zero[PROTO_AXES_N], uint8_t out[CALIB_RECORD_SIZE])
{
    uint8_t *p = out;
    *p++ = CALIB_MAGIC0;
    *p++ = CALIB_MAGIC1;
    *p++ = CALIB_LAYOUT;
    for (int i = 0; i < PROTO_AXES_N; i++) {
        *p++ = (uint8_t)zero[i];
        *p++ = (uint8_t)(zero[i] >> 8);
    }
    uint16_t crc = crc16_ccitt(out, (size_t)(p - out));
    *p++ = (uint8_t)crc;
    *p = (uint8_t)(crc >> 8);
}

int calib_unpack(const uint8_t in[CALIB_RECORD_SIZE], uint16_t zero[PROTO_AXES_N])
{
    uint16_t tmp[PROTO_AXES_N];

    if (in[0] != CALIB_MAGIC0 || in[1] != CALIB_MAGIC1 || in[2] != CALIB_LAYOUT)
        return 0;
    uint16_t crc = (uint16_t)(in[CALIB_RECORD_SIZE - 2] | (in[CALIB_RECORD_SIZE - 1] << 8));
    if (crc16_ccitt(in, CALIB_RECORD_SIZE - 2) != crc)
        return 0;
    for (int i = 0; i < PROTO_AXES_N; i++) {
        tmp[i] = (uint16_t)(in[3 + 2 * i] | (in[4 + 2 * i] << 8));
        if (tmp[i] > AXIS_C16_MAX)
            return 0;
    }
    for (int i = 0; i < PROTO_AXES_N; i++)
        zero[i] = tmp[i];
    return 1;
}

uint8_t calib_choose(const uint16_t measured[PROTO_AXES_N], const uint16_t *stored,
                     uint16_t tolerance, uint16_t out[PROTO_AXES_N])
{
    uint8_t kept = 0;

    for (int i = 0; i < PROTO_AXES_N; i++) {
        out[i] = measured[i];
        if (!stored)
            continue;
        int32_t d = (int32_t)measured[i] - (int32_t)stored[i];
        if (d > tolerance || d < -(int32_t)tolerance) {
            out[i] = stored[i];
            kept |= (uint8_t)(1u << i);
        }
    }
    return kept;
}

void calib_gesture_init(struct calib_gesture *g)
{
    g->held = 0;
    g->fired = 0;
}

int calib_gesture_step(struct calib_gesture *g, uint8_t buttons, uint8_t mask, uint16_t hold_ticks)
{
    if ((buttons & mask) != mask) {
        g->held = 0;
        g->fired = 0;
        return 0;
    }
    if (g->fired)
        return 0;
    if (++g->held >= hold_ticks) {
        g->fired = 1;
        return 1;
    }
    return 0;
}
