/* Build-time settings of the 6-axis controller. Values that the host must know are sent in the
 * hello (rates) or documented in firmware/PROTOCOL.md (scaling). */
#ifndef CONTROLLER_CONFIG_H
#define CONTROLLER_CONFIG_H

#define FW_VERSION_MAJOR 1
#define FW_VERSION_MINOR 1
#define FW_VERSION_PATCH 0
#define BOARD_ID 1 /* 6-axis controller */

#define BAUD 115200UL

#define N_BUTTONS 5
#define BUTTON_SHIFT 2     /* buttons on PD2..PD6 (Nano D2..D6), active low with pull-ups */
#define DEBOUNCE_MS 5      /* sampled every 1 ms */
#if BUTTON_SHIFT + N_BUTTONS > 7
#error "the buttons must stay on PD2..PD6: PD0/PD1 are the UART, and the AXES buttons byte has 8 bits"
#endif

#define FRAME_HZ 100
#define TICK_MS (1000 / FRAME_HZ)
#define HEARTBEAT_MS 250
#define LINGER_MS 500      /* keep sending axes this long after the last activity */

#define FILTER_SHIFT 2     /* IIR alpha 1/4 at 100 Hz: time constant about 35 ms */
#define OVERSAMPLE 4       /* conversions summed per axis per tick */
#define DEADZONE_C16 (12 * 16)   /* +-12 ADC counts: about 2.3 % of half scale */
#define EDGE_C16 (16 * 16)       /* full scale 16 counts short of the rail */
#define CAL_TOLERANCE_C16 (48 * 16) /* power-up zero further than this from EEPROM: stick held */
#define CAL_BOOT_TICKS 16  /* ticks averaged for the power-up zero */

#define GESTURE_MASK 0x03  /* buttons 1 and 2 ... */
#define GESTURE_MS 3000    /* ... held for 3 s store the current position as zero */

#endif
