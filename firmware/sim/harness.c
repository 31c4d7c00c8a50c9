/* Runs an AVR firmware in simavr with its UART bridged to a pseudo-terminal, so a host program
 * opens the pty as it would open the real board's serial port.
 *
 *   harness [--mcu atmega328p] [--freq 16000000] [--vcc 5000] [--speed X] [--eeprom FILE]
 *           FIRMWARE.elf
 *
 * Prints "pty PATH" once the pty exists, then obeys lines on stdin, answering each with
 * "ok ..." (or "error ...") once it has taken effect:
 *   adc CH MV          drive ADC channel CH with MV millivolts
 *   pin PORT BIT LEVEL drive an input pin (e.g. "pin D 2 0": button 1 pressed; the
 *                      controller's buttons 1..5 are PD2..PD6, "pin D 6 0" is button 5)
 *   run                start the CPU (it waits, so the host can open the pty first)
 *   pause              stop the CPU (simulated time stands still: a hung line, no reset)
 *   reset              the reset button (MCUSR says external)
 *   uart HEX           bytes into the UART as if the host had sent them (e.g. a command)
 *   tx HEX             bytes onto the line towards the host (noise), beside the firmware's
 *   time               report the simulated time: "ok time US"
 *   bytes              report the bytes on the line so far: "ok bytes tx N rx M", N written
 *                      towards the host (the firmware's and tx noise; dropped ones not counted),
 *                      M read from the host; a test pauses the CPU, reads N and knows which of
 *                      the bytes it receives were sent before an input changed, or waits for M
 *                      to know the firmware will see a command from the simulated instant it
 *                      runs again, however late the machine got round to either
 *   stats              CPU load since the last stats: "ok stats bursts N max_burst CYCLES
 *                      max_window CYCLES window CYCLES"; a burst is the CPU awake between two
 *                      sleeps (one main-loop iteration, with the interrupts inside it), a window
 *                      is one 10 ms slice of simulated time (the loop's budget)
 *   quit
 * and reports a CPU reset (watchdog, ...) with a line "reset at US" (simulated time) whenever it happens.
 * --speed X paces simulated time at X times real time (0: as fast as possible). Bytes the
 * firmware sends while nobody reads the pty are dropped, as on a real line.
 * --eeprom FILE keeps the EEPROM in FILE, as the chip keeps it across power cycles: read at
 * start (a missing file is an erased EEPROM, all 0xFF), written back whenever the firmware has
 * changed it, so stopping the harness (an unplug) and starting it again (a replug) is a power
 * cycle that keeps the stored calibration. */
#define _GNU_SOURCE
#include <errno.h>
#include <stdarg.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "avr_adc.h"
#include "avr_eeprom.h"
#include "avr_ioport.h"
#include "avr_uart.h"
#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_irq.h"
#include "sim_regbit.h"

static avr_t *avr;
static int master_fd = -1;
static double sim_seconds(void);
static double speed = 1.0;
static int running;
static volatile sig_atomic_t quitting;

/* ---- UART <-> pty ---- */

static uint8_t in_buf[4096];
static size_t in_len, in_pos;
static int uart_xon = 1;
static avr_irq_t *uart_in_irq;
static unsigned long long tx_count, rx_count; /* bytes written to / read from the pty */

static void uart_out_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq, (void)param;
    uint8_t b = (uint8_t)value;
    /* Non-blocking: with nobody reading, the pty fills and bytes are lost, like on a wire. */
    static int dropping;
    if (write(master_fd, &b, 1) == 1) {
        tx_count++;
        dropping = 0;
    } else if (errno != EAGAIN) {
        perror("harness: pty write");
    } else if (!dropping) {
        dropping = 1; /* once per burst: the log says where a reader fell behind */
        fprintf(stderr, "harness: pty full, dropping bytes at %.3f s\n", sim_seconds());
    }
}

static void uart_xon_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq, (void)value, (void)param;
    uart_xon = 1;
}

static void uart_xoff_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq, (void)value, (void)param;
    uart_xon = 0;
}

/* Hands queued host bytes to the UART while its receive FIFO has room. */
static void feed_uart(void)
{
    while (uart_xon && in_pos < in_len)
        avr_raise_irq(uart_in_irq, in_buf[in_pos++]);
    if (in_pos == in_len)
        in_pos = in_len = 0;
}

static void read_pty(void)
{
    if (in_len == sizeof in_buf)
        return;
    ssize_t n = read(master_fd, in_buf + in_len, sizeof in_buf - in_len);
    if (n > 0) {
        in_len += (size_t)n;
        rx_count += (unsigned long long)n;
    }
}

static void uart_connect(void)
{
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
    /* No console echo of firmware output, no usleep when the firmware polls the UART. */
    flags &= ~(uint32_t)(AVR_UART_FLAG_STDIO | AVR_UART_FLAG_POLL_SLEEP);
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);

    uart_in_irq = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                            uart_out_hook, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON),
                            uart_xon_hook, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF),
                            uart_xoff_hook, NULL);
}

static int open_pty(char *path, size_t cap)
{
    master_fd = posix_openpt(O_RDWR | O_NOCTTY);
    if (master_fd < 0 || grantpt(master_fd) || unlockpt(master_fd))
        return -1;
    if (ptsname_r(master_fd, path, cap))
        return -1;
    /* Keep a slave fd open for the harness's lifetime: the line settings stay raw (no echo of
     * firmware bytes back into the UART, no newline mangling) and the master never sees EIO
     * while the host has the port closed. */
    int slave = open(path, O_RDWR | O_NOCTTY);
    if (slave < 0)
        return -1;
    struct termios t;
    if (tcgetattr(slave, &t))
        return -1;
    cfmakeraw(&t);
    if (tcsetattr(slave, TCSANOW, &t))
        return -1;
    return fcntl(master_fd, F_SETFL, fcntl(master_fd, F_GETFL) | O_NONBLOCK);
}

/* ---- EEPROM kept in a file ---- */

static const char *eeprom_path;
static uint8_t ee_saved[4096];
static uint32_t ee_size;

/* simavr 1.6's EEPROM ioctls return -1 when they worked (a bug: their result is never set) and
 * -2 for a bad argument; later versions return 0. So only below -1 is a failure. */
static int eeprom_get(uint8_t *buf)
{
    avr_eeprom_desc_t d = { .ee = buf, .offset = 0, .size = ee_size };
    return avr_ioctl(avr, AVR_IOCTL_EEPROM_GET, &d) < -1 ? -1 : 0;
}

static int eeprom_load(void)
{
    ee_size = avr->e2end + 1;
    if (ee_size > sizeof ee_saved) {
        fprintf(stderr, "harness: EEPROM of %u bytes is larger than supported\n", ee_size);
        return -1;
    }
    memset(ee_saved, 0xFF, ee_size); /* erased */
    FILE *f = fopen(eeprom_path, "rb");
    if (f) {
        size_t n = fread(ee_saved, 1, ee_size, f);
        int extra = fgetc(f) != EOF;
        fclose(f);
        if (extra || n != ee_size) {
            fprintf(stderr, "harness: %s: EEPROM image must be %u bytes\n", eeprom_path, ee_size);
            return -1;
        }
    } else if (errno != ENOENT) {
        fprintf(stderr, "harness: %s: %s\n", eeprom_path, strerror(errno));
        return -1;
    }
    avr_eeprom_desc_t d = { .ee = ee_saved, .offset = 0, .size = ee_size };
    if (avr_ioctl(avr, AVR_IOCTL_EEPROM_SET, &d) < -1) {
        fprintf(stderr, "harness: cannot load the EEPROM image\n");
        return -1;
    }
    return 0;
}

/* Writes the EEPROM image back when the firmware changed it: to a temporary file renamed over
 * the old one, so a harness killed mid-write leaves the previous image, not half of one. */
static void eeprom_sync(void)
{
    uint8_t now[sizeof ee_saved];
    if (!eeprom_path || eeprom_get(now) < 0 || !memcmp(now, ee_saved, ee_size))
        return;
    char tmp[4200];
    snprintf(tmp, sizeof tmp, "%s.tmp", eeprom_path);
    FILE *f = fopen(tmp, "wb");
    if (!f || fwrite(now, 1, ee_size, f) != ee_size || fclose(f) || rename(tmp, eeprom_path)) {
        perror("harness: EEPROM image");
        return;
    }
    memcpy(ee_saved, now, ee_size);
}

/* ---- CPU load: cycles awake between sleeps ---- */

static uint64_t sim_cycles(void);
static uint64_t burst_start, bursts, max_burst, window_start, window_busy, max_window;
static int awake = 1;

static void window_add(uint64_t from, uint64_t to)
{
    uint64_t w = avr->frequency / 100; /* 10 ms */
    while (from < to) {
        uint64_t end = window_start + w;
        if (from >= end) { /* a new window: the last one is complete */
            if (window_busy > max_window)
                max_window = window_busy;
            window_busy = 0;
            window_start = from - (from - window_start) % w;
            continue;
        }
        uint64_t upto = to < end ? to : end;
        window_busy += upto - from;
        from = upto;
    }
}

/* The core calls sleep_hook (below) for every stretch of sleep, before it adds the stretch to
 * avr->cycle; one avr_run() may sleep and wake again, so the state seen between calls misses
 * sleeps. A burst ends where a sleep begins and starts where the last stretch ends. */
static uint64_t sleep_until;

static void sleep_begins(avr_cycle_count_t how_long)
{
    uint64_t c = sim_cycles();
    if (awake) {
        bursts++;
        if (c - burst_start > max_burst)
            max_burst = c - burst_start;
        window_add(burst_start, c);
        awake = 0;
    }
    sleep_until = c + 1 + how_long;
}

static void track_wake(void)
{
    if (!awake && avr->state != cpu_Sleeping) {
        awake = 1;
        burst_start = sleep_until;
    }
}

static int hex_bytes(const char *hex, uint8_t *out, size_t cap)
{
    size_t n = 0;
    unsigned v;
    while (*hex == ' ')
        hex++;
    while (hex[0] && hex[1] && n < cap && sscanf(hex, "%2x", &v) == 1) {
        out[n++] = (uint8_t)v;
        hex += 2;
    }
    return *hex ? -1 : (int)n;
}

/* ---- commands on stdin ---- */

static char cmd_buf[256];
static size_t cmd_len;
static FILE *out; /* replies; simavr's own printf chatter is sent to stderr */

static void reply(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static void reply(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vfprintf(out, fmt, ap);
    va_end(ap);
    fputc('\n', out);
    fflush(out);
}

static uint8_t ext_mask[26], ext_value[26];

/* simavr clears the PIN registers on reset but keeps each pin IRQ's last value, so raising the
 * same level again is filtered out and a released button would read as pressed. Re-drive every
 * pin the host set, through the opposite level, before the firmware runs again. */
static void redrive_pins(void)
{
    for (int k = 0; k < 26; k++)
        for (int bit = 0; bit < 8; bit++) {
            if (!(ext_mask[k] & (1u << bit)))
                continue;
            avr_irq_t *irq = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('A' + k), bit);
            uint32_t level = (ext_value[k] >> bit) & 1u;
            avr_raise_irq(irq, !level);
            avr_raise_irq(irq, level);
        }
}

static uint64_t cycle_offset; /* keeps simulated time monotonic should a reset rewind avr->cycle */

static uint64_t sim_cycles(void)
{
    return avr->cycle + cycle_offset;
}

static double sim_seconds(void)
{
    return (double)sim_cycles() / avr->frequency;
}

static void (*core_reset)(avr_t *);
static int reset_seen;

static void reset_hook(avr_t *a)
{
    if (core_reset)
        core_reset(a);
    reset_seen = 1;
}

static void command(char *line)
{
    char port;
    int ch, mv, bit, level;

    if (sscanf(line, "adc %d %d", &ch, &mv) == 2 && ch >= 0 && ch < 8 && mv >= 0) {
        avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0 + ch), (uint32_t)mv);
        reply("ok adc %d %d", ch, mv);
    } else if (sscanf(line, "pin %c %d %d", &port, &bit, &level) == 3 && bit >= 0 && bit < 8) {
        avr_irq_t *irq = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(port), bit);
        if (!irq) {
            reply("error no port %c", port);
            return;
        }
        /* Also the port's "external" default: simavr applies it whenever the firmware makes
         * the pin an input, so the level survives a reset like a real pull-up or switch. */
        int k = port - 'A';
        if (k >= 0 && k < 26) {
            ext_mask[k] |= (uint8_t)(1u << bit);
            ext_value[k] = (uint8_t)((ext_value[k] & ~(1u << bit)) | ((level ? 1u : 0u) << bit));
            avr_ioport_external_t e = { .name = (unsigned char)port, .mask = ext_mask[k],
                                        .value = ext_value[k] };
            avr_ioctl(avr, AVR_IOCTL_IOPORT_SET_EXTERNAL(port), &e);
        }
        avr_raise_irq(irq, level ? 1 : 0);
        reply("ok pin %c %d %d", port, bit, level ? 1 : 0);
    } else if (strcmp(line, "run") == 0) {
        running = 1;
        reply("ok run");
    } else if (strcmp(line, "pause") == 0) {
        running = 0;
        reply("ok pause");
    } else if (strcmp(line, "reset") == 0) {
        avr_reset(avr);
        avr_regbit_set(avr, avr->reset_flags.extrf);
        reply("ok reset");
    } else if (strncmp(line, "uart ", 5) == 0 || strncmp(line, "tx ", 3) == 0) {
        uint8_t bytes[sizeof in_buf];
        int to_uart = line[0] == 'u';
        int n = hex_bytes(line + (to_uart ? 5 : 3), bytes, sizeof bytes);
        if (n < 0 || (to_uart && (size_t)n > sizeof in_buf - in_len)) {
            reply("error bad or too many bytes: %s", line);
            return;
        }
        if (to_uart) {
            memcpy(in_buf + in_len, bytes, (size_t)n);
            in_len += (size_t)n;
        } else if (n) {
            ssize_t w = write(master_fd, bytes, (size_t)n);
            if (w > 0)
                tx_count += (unsigned long long)w;
            else if (w < 0 && errno != EAGAIN)
                perror("harness: pty write");
        }
        reply("ok %s %d", to_uart ? "uart" : "tx", n);
    } else if (strcmp(line, "stats") == 0) {
        window_add(sim_cycles(), sim_cycles()); /* close a finished window */
        reply("ok stats bursts %llu max_burst %llu max_window %llu window %llu",
              (unsigned long long)bursts, (unsigned long long)max_burst,
              (unsigned long long)max_window, (unsigned long long)(avr->frequency / 100));
        bursts = max_burst = max_window = 0;
    } else if (strcmp(line, "bytes") == 0) {
        reply("ok bytes tx %llu rx %llu", tx_count, rx_count);
    } else if (strcmp(line, "time") == 0) {
        reply("ok time %.0f", sim_seconds() * 1e6);
    } else if (strcmp(line, "quit") == 0) {
        quitting = 1;
        reply("ok quit");
    } else {
        reply("error unknown command: %s", line);
    }
}

static void read_stdin(void)
{
    ssize_t n = read(STDIN_FILENO, cmd_buf + cmd_len, sizeof cmd_buf - 1 - cmd_len);
    if (n <= 0) {
        quitting = 1; /* the test went away */
        return;
    }
    cmd_len += (size_t)n;
    char *nl;
    while ((nl = memchr(cmd_buf, '\n', cmd_len))) {
        *nl = 0;
        command(cmd_buf);
        size_t used = (size_t)(nl + 1 - cmd_buf);
        memmove(cmd_buf, nl + 1, cmd_len - used);
        cmd_len -= used;
    }
    if (cmd_len == sizeof cmd_buf - 1)
        cmd_len = 0; /* an overlong line: drop it */
}

/* ---- pacing ---- */

static double wall_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

/* The core advances avr->cycle over sleeps by itself; simavr's default callback would also
 * usleep in real time, which --speed replaces. */
static void on_signal(int sig)
{
    (void)sig;
    quitting = 1; /* the loop ends, the EEPROM is written back */
}

static void sleep_hook(avr_t *a, avr_cycle_count_t how_long)
{
    (void)a;
    sleep_begins(how_long);
}

static void service(int timeout_ms)
{
    struct pollfd p[2] = { { STDIN_FILENO, POLLIN, 0 }, { master_fd, POLLIN, 0 } };
    if (poll(p, 2, timeout_ms) > 0) {
        if (p[0].revents & (POLLIN | POLLHUP))
            read_stdin();
        if (p[1].revents & POLLIN)
            read_pty();
    }
    feed_uart();
}

int main(int argc, char **argv)
{
    const char *mcu = "atmega328p", *elf = NULL;
    uint32_t freq = 16000000, vcc = 5000;

    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--mcu") && i + 1 < argc)
            mcu = argv[++i];
        else if (!strcmp(argv[i], "--freq") && i + 1 < argc)
            freq = (uint32_t)strtoul(argv[++i], NULL, 0);
        else if (!strcmp(argv[i], "--vcc") && i + 1 < argc)
            vcc = (uint32_t)strtoul(argv[++i], NULL, 0);
        else if (!strcmp(argv[i], "--speed") && i + 1 < argc)
            speed = strtod(argv[++i], NULL);
        else if (!strcmp(argv[i], "--eeprom") && i + 1 < argc)
            eeprom_path = argv[++i];
        else if (argv[i][0] != '-' && !elf)
            elf = argv[i];
        else {
            fprintf(stderr, "usage: %s [--mcu M] [--freq HZ] [--vcc MV] [--speed X] [--eeprom FILE] "
                            "FIRMWARE.elf\n",
                    argv[0]);
            return 2;
        }
    }
    if (!elf) {
        fprintf(stderr, "harness: no firmware given\n");
        return 2;
    }

    out = fdopen(dup(STDOUT_FILENO), "w");
    if (!out || dup2(STDERR_FILENO, STDOUT_FILENO) < 0) {
        perror("harness: stdout");
        return 1;
    }

    elf_firmware_t fw;
    memset(&fw, 0, sizeof fw);
    if (elf_read_firmware(elf, &fw)) {
        fprintf(stderr, "harness: cannot read %s\n", elf);
        return 1;
    }
    avr = avr_make_mcu_by_name(mcu);
    if (!avr) {
        fprintf(stderr, "harness: unknown mcu %s\n", mcu);
        return 1;
    }
    avr_init(avr);
    avr->log = LOG_ERROR; /* stdout belongs to the command protocol */
    fw.frequency = freq;
    fw.vcc = fw.avcc = fw.aref = vcc;
    avr_load_firmware(avr, &fw);
    if (eeprom_path && eeprom_load())
        return 1;
    avr->sleep = sleep_hook;
    signal(SIGTERM, on_signal);
    signal(SIGINT, on_signal);
    core_reset = avr->reset;
    avr->reset = reset_hook;

    char path[128];
    if (open_pty(path, sizeof path)) {
        perror("harness: pty");
        return 1;
    }
    uart_connect();
    reply("pty %s", path);

    double t0 = 0, sim0 = 0;
    while (!quitting) {
        if (!running) {
            service(-1);
            t0 = wall_now();
            sim0 = sim_seconds();
            continue;
        }
        for (int i = 0; i < 2000; i++) {
            uint64_t before = avr->cycle;
            int state = avr_run(avr);
            if (state == cpu_Done || state == cpu_Crashed) {
                eeprom_sync();
                reply("exit %s", state == cpu_Done ? "done" : "crashed");
                return state == cpu_Done ? 0 : 1;
            }
            if (reset_seen || avr->cycle < before) {
                reset_seen = 0;
                if (avr->cycle < before)
                    cycle_offset += before - avr->cycle;
                redrive_pins();
                reply("reset at %.0f", sim_seconds() * 1e6);
            }
            track_wake();
        }
        int wait_ms = 0;
        if (speed > 0) {
            double ahead = (sim_seconds() - sim0) / speed - (wall_now() - t0);
            if (ahead > 0.001)
                wait_ms = (int)(ahead * 1000);
        }
        service(wait_ms);
        eeprom_sync();
    }
    eeprom_sync();
    return 0;
}
