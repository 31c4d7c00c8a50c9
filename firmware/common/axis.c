#include "axis.h"

#include "proto.h"

void axis_filter_init(struct axis_filter *f, uint8_t shift)
{
    f->state = 0;
    f->shift = shift;
    f->primed = 0;
}

uint16_t axis_filter_step(struct axis_filter *f, uint16_t x)
{
    int32_t target = (int32_t)x << 4;

    if (!f->primed) {
        f->state = target;
        f->primed = 1;
    } else {
        /* Division, not >>, so the step rounds toward zero on both sides of the target. */
        f->state += (target - f->state) / ((int32_t)1 << f->shift);
    }
    return (uint16_t)((f->state + 8) >> 4);
}

int16_t axis_scale(uint16_t value, uint16_t zero, const struct axis_cfg *cfg)
{
    int32_t d = (int32_t)value - (int32_t)zero;
    int32_t span = d >= 0 ? (int32_t)AXIS_C16_MAX - zero : (int32_t)zero;
    int32_t mag = (d >= 0 ? d : -d) - cfg->deadzone;
    int32_t range = span - cfg->deadzone - cfg->edge;

    if (mag <= 0 || range <= 0)
        return 0;
    int32_t out = (mag * PROTO_AXIS_FULL + range / 2) / range;
    if (out > PROTO_AXIS_FULL)
        out = PROTO_AXIS_FULL;
    return (int16_t)(d >= 0 ? out : -out);
}
