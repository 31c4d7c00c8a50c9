#include "knob_report.h"

void knob_report_init(struct knob_report *r, const uint8_t counts[KNOB_N], uint8_t buttons)
{
    for (int i = 0; i < KNOB_N; i++)
        r->sent[i] = counts[i];
    r->buttons = buttons & 0x7F;
}

int knob_report_build(struct knob_report *r, const uint8_t counts[KNOB_N], uint8_t buttons,
                      int force, uint8_t out[KNOB_REPORT_SIZE])
{
    int changed = force;

    buttons &= 0x7F;
    out[0] = KNOB_REPORT_ID;
    for (int i = 0; i < KNOB_N; i++) {
        /* Modular difference: a count that wrapped 255 -> 0 is still +1. */
        int16_t d = (int8_t)(uint8_t)(counts[i] - r->sent[i]);
        if (d < -127)
            d = -127; /* -128 is outside the descriptor's logical range */
        r->sent[i] = (uint8_t)(r->sent[i] + d);
        out[1 + i] = (uint8_t)(int8_t)d;
        changed |= d != 0;
    }
    out[1 + KNOB_N] = buttons;
    changed |= buttons != r->buttons;
    r->buttons = buttons;
    return changed ? KNOB_REPORT_SIZE : 0;
}
