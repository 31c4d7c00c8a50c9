/* Debounces up to 8 active-high inputs sampled at a fixed rate: an input changes state only
 * after `n` consecutive samples disagree with it, so contact bounce shorter than n samples is
 * never seen. Plain C. */
#ifndef FW_DEBOUNCE_H
#define FW_DEBOUNCE_H

#include <stdint.h>

struct debounce {
    uint8_t state;
    uint8_t n;
    uint8_t count[8];
};

void debounce_init(struct debounce *d, uint8_t n, uint8_t initial);
/* Feeds one raw sample (bit set = pressed); returns the debounced state. */
uint8_t debounce_step(struct debounce *d, uint8_t raw);

#endif
