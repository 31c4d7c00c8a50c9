#include "debounce.h"

void debounce_init(struct debounce *d, uint8_t n, uint8_t initial)
{
    d->state = initial;
    d->n = n ? n : 1;
    for (int i = 0; i < 8; i++)
        d->count[i] = 0;
}

uint8_t debounce_step(struct debounce *d, uint8_t raw)
{
    uint8_t diff = (uint8_t)(raw ^ d->state);

    for (uint8_t i = 0; i < 8; i++) {
        uint8_t bit = (uint8_t)(1u << i);
        if (!(diff & bit)) {
            d->count[i] = 0;
        } else if (++d->count[i] >= d->n) {
            d->state ^= bit;
            d->count[i] = 0;
        }
    }
    return d->state;
}
