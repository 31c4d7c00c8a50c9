#include "quad.h"

/* Index: last << 2 | now. Clockwise is 00 -> 01 -> 11 -> 10 -> 00. */
static const int8_t quad_table[16] = {
    /* now:  00  01  10  11 */
    /* 00 */ 0, +1, -1, 0,
    /* 01 */ -1, 0, 0, +1,
    /* 10 */ +1, 0, 0, -1,
    /* 11 */ 0, -1, +1, 0,
};

void quad_init(struct quad *q, uint8_t ab, uint8_t steps_per_detent)
{
    q->last = ab & 3;
    q->acc = 0;
    q->steps = steps_per_detent ? steps_per_detent : 4;
    q->count = 0;
    q->errors = 0;
}

int8_t quad_update(struct quad *q, uint8_t ab)
{
    ab &= 3;
    uint8_t idx = (uint8_t)(q->last << 2 | ab);
    /* Both bits changed (00<->11, 01<->10): direction unknown, count nothing. */
    if ((q->last ^ ab) == 3 && q->errors < 0xFFFF)
        q->errors++;
    q->last = ab;
    q->acc = (int8_t)(q->acc + quad_table[idx]);

    /* Count a detent when a full detent's worth of steps has accumulated in one direction. A
     * bounce right after the detent steps back to -1 and forward to 0: no double count. */
    if (q->acc >= (int8_t)q->steps) {
        q->acc = 0;
        q->count++;
        return 1;
    }
    if (q->acc <= -(int8_t)q->steps) {
        q->acc = 0;
        q->count--;
        return -1;
    }
    return 0;
}
