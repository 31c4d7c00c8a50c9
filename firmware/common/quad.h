/* Quadrature encoder decoding by Gray-code transition table. Each sample is the 2-bit state
 * (A << 1 | B). A valid step (one bit changed) counts +-1 quarter step; no change and invalid
 * jumps (both bits changed: a missed sample) count 0. Contact bounce is a step back and forth,
 * so it cancels instead of accumulating. Plain C. */
#ifndef FW_QUAD_H
#define FW_QUAD_H

#include <stdint.h>

struct quad {
    uint8_t last;   /* previous AB state */
    int8_t acc;     /* quarter steps since the last detent */
    uint8_t steps;  /* quarter steps per detent: 4 (full-cycle encoders) or 2 */
    uint8_t count;  /* detents, modulo 256: the report sends differences, so wrap is harmless */
    uint16_t errors; /* invalid transitions seen: the scan rate is too low for the knob */
};

void quad_init(struct quad *q, uint8_t ab, uint8_t steps_per_detent);
/* Feeds one sample; returns the detents completed by it (-1, 0 or +1). */
int8_t quad_update(struct quad *q, uint8_t ab);

#endif
