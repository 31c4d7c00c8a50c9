#include "sched.h"

void sched_init(struct sched *s, uint16_t linger_ticks, uint16_t hb_ticks)
{
    s->linger_ticks = linger_ticks;
    s->hb_ticks = hb_ticks ? hb_ticks : 1;
    s->linger_left = 0;
    s->hb_count = 0;
}

enum sched_action sched_tick(struct sched *s, int active)
{
    if (active) {
        s->linger_left = s->linger_ticks;
        s->hb_count = 0;
        return SCHED_AXES;
    }
    if (s->linger_left) {
        s->linger_left--;
        return SCHED_AXES;
    }
    /* Heartbeats count from the last frame sent, so the line is never silent longer than
     * one heartbeat period. */
    if (++s->hb_count >= s->hb_ticks) {
        s->hb_count = 0;
        return SCHED_HEARTBEAT;
    }
    return SCHED_NONE;
}
