/* The knob box's Gray-code decoder (firmware/common/quad.c) as avr-gcc builds it, on a simulated
 * ATmega328P: encoder samples arrive over the UART (one byte, the AB state, each), detents and
 * counters go back. Used by tests/firmware/test_encoder_bounce.py; not part of any board.
 *
 *   0x80 | steps << 2 | ab0   start decoding from state ab0 with steps quarter steps per detent
 *   0x00 .. 0x03              one sample
 *   0xFF                      report: count, errors (LE), detents up (LE), detents down (LE), 0x0A
 * A detent is also echoed at once as '+' or '-', so the host sees their order. */
#include <avr/io.h>

#include "quad.h"

static void tx(uint8_t b)
{
    while (!(UCSR0A & _BV(UDRE0)))
        ;
    UDR0 = b;
}

static uint8_t rx(void)
{
    while (!(UCSR0A & _BV(RXC0)))
        ;
    return UDR0;
}

int main(void)
{
    struct quad q;
    uint16_t up = 0, down = 0;

    UCSR0A = _BV(U2X0);
    UBRR0 = 16; /* 115200 at 16 MHz with U2X */
    UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);
    UCSR0B = _BV(RXEN0) | _BV(TXEN0);
    quad_init(&q, 0, 4);
    for (;;) {
        uint8_t b = rx();
        if (b == 0xFF) {
            uint8_t out[] = { q.count, (uint8_t)q.errors, (uint8_t)(q.errors >> 8), (uint8_t)up,
                              (uint8_t)(up >> 8), (uint8_t)down, (uint8_t)(down >> 8), 0x0A };
            for (uint8_t i = 0; i < sizeof out; i++)
                tx(out[i]);
        } else if (b & 0x80) {
            quad_init(&q, b & 3, (b >> 2) & 0x0F);
            up = down = 0;
        } else {
            int8_t d = quad_update(&q, b);
            if (d > 0) {
                up++;
                tx('+');
            } else if (d < 0) {
                down++;
                tx('-');
            }
        }
    }
}
