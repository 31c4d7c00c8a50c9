/* What the controller sends on each 10 ms tick: axes frames while a visitor is active (and for
 * a short linger after, so the host sees the release as zeros), otherwise a heartbeat every
 * `hb_ticks`. Plain C. */
#ifndef FW_SCHED_H
#define FW_SCHED_H

#include <stdint.h>

enum sched_action { SCHED_NONE = 0, SCHED_AXES = 1, SCHED_HEARTBEAT = 2 };

struct sched {
    uint16_t linger_ticks, hb_ticks;
    uint16_t linger_left, hb_count;
};

void sched_init(struct sched *s, uint16_t linger_ticks, uint16_t hb_ticks);
/* active: any axis outside its dead zone or any button pressed on this tick. */
enum sched_action sched_tick(struct sched *s, int active);

#endif
