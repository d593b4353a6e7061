/*
 * Runs the uno_acq firmware in simavr (libsimavr) on a simulated bench:
 * drives the ADC pins from a table of V, I and speed through the divider and
 * shunt gains, the encoder pins in quadrature from the speed, and records
 * what the board sends:
 *
 *   <out>/host.txt     bytes of the USB serial (the bench log lines)
 *   <out>/link.bin     bytes of the ESP8266 link, decoded from the D11 pin edges
 *   <out>/windows.csv  per closed sample window: seq, cycle of the close,
 *                      driven pin voltages, driven speed, encoder counts
 *                      driven
 *   <out>/adc_isr.csv  per ADC interrupt: entry cycle, cycles to reti (nested
 *                      ones included), ADATE at entry (uno_sim_ripple.h)
 *   <out>/busy.csv     the main loop's work per window (GPIOR1 1..2), the
 *                      observer step in it (GPIOR1 3..4) and the ripple counter's
 *                      window step (GPIOR1 5..6, the counting build): kind, start
 *                      cycle, cycles
 *
 * A window closes when the firmware writes its marker to GPIOR0; the cycle
 * of that write is exact, so the period jitter is measured, not estimated.
 *
 * usage: uno_sim <elf> <drive.csv> <outdir> <windows> <command>...
 * The divider ratio, shunt and encoder counts are the bench's, from
 * uno_acq/bench_gen.h (generated from tools/hpddo/bench.py).
 * drive.csv: lines "v_V,i_A,rpm" (no header); window k uses line k mod n.
 * Each command is sent (with a newline) once the previous one was answered;
 * the run ends after <windows> log rows or a "! end" line.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "avr_adc.h"
#include "avr_ioport.h"
#include "avr_uart.h"
#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_io.h"
#include "sim_irq.h"
#include "sim_cycle_timers.h"
#include "avr_timer.h"

#include "bench_gen.h"

#define F_CPU HPDDO_BENCH_CPU_HZ
#define GPIOR0_ADDR 0x3E
#define GPIOR1_ADDR 0x4A
#define MAX_BUSY 200000
/* Bit period of the link: (OCR2A + 1) * 8 = 416 cycles on the chip; simavr's
 * CTC mode counts OCR2A * 8, so the decoder measures it instead. */
static double link_bit_cycles = 416.0;
#define MAX_ROWS 4096
#define MAX_WINDOWS 100000
#define MAX_EDGES 4000000
#define MAX_HOST 2000000

typedef struct { double v_V, i_A, rpm; } drive_row_t;

static avr_t* avr;
static drive_row_t drive[MAX_ROWS];
static int n_drive;
static const double ratio = HPDDO_BENCH_DIVIDER_RATIO;
static const double shunt_ohm = HPDDO_BENCH_SHUNT_OHM * HPDDO_BENCH_SHUNT_GAIN;
static const double cpr = HPDDO_BENCH_ENCODER_COUNTS_PER_REV; /* output shaft */

/* window bookkeeping */
typedef struct {
  long seq;
  avr_cycle_count_t close;
  unsigned v_mV, i_mV;
  double rpm;
  long edges;
} window_t;
static window_t* windows;
static long n_windows; /* closed */
static long seq_now = -1;  /* seq of the open window, once known */
static int seq_errors;
static unsigned cur_v_mV, cur_i_mV;
static double cur_rpm;
static long cur_edges;

/* encoder */
static int enc_phase; /* 0..3 along 00 01 11 10 */
static double enc_frac;

/* host serial */
static char* host;
static long n_host;
static long host_scan; /* parsed up to here */
static int rows_seen, header_seen, end_seen, answers;

/* link pin */
static avr_cycle_count_t* edge_cycle;
static unsigned char* edge_level;
static long n_edges;
static avr_cycle_count_t comp_cycle[64]; /* first compare matches: the bit clock */
static long n_comp;

#include "uno_sim_ripple.h"

static unsigned pin_mV(double v) {
  double mv = v * 1000.0;
  if (mv < 0) mv = 0;
  if (mv > 4900) mv = 4900;
  return (unsigned)(mv + 0.5);
}

static void set_inputs(long window_index) {
  const drive_row_t* r = &drive[window_index % n_drive];
  cur_v_mV = pin_mV(r->v_V / ratio);
  cur_i_mV = pin_mV(r->i_A * shunt_ohm);
  cur_rpm = r->rpm;
  avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0), cur_v_mV);
  rip_cur_i_mV = cur_i_mV;
  if (!rip_on) /* the ripple mode feeds A1 at each conversion's start (uno_sim_ripple.h) */
    avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC1), cur_i_mV);
}

static avr_cycle_count_t encoder_tick(struct avr_t* a, avr_cycle_count_t when, void* param);

static void marker_write(avr_t* a, avr_io_addr_t addr, uint8_t v, void* param) {
  (void)param;
  a->data[addr] = v;
  if (seq_now < 0) seq_now = v;
  if ((seq_now & 0xFF) != v) {
    seq_errors++;
    seq_now = (seq_now & ~0xFFL) | v;
  }
  if (n_windows < MAX_WINDOWS) {
    window_t* w = &windows[n_windows++];
    w->seq = seq_now;
    w->close = a->cycle;
    w->v_mV = cur_v_mV;
    w->i_mV = cur_i_mV;
    w->rpm = cur_rpm;
    w->edges = cur_edges;
  }
  seq_now++;
  cur_edges = 0;
  set_inputs(n_windows);
  /* the encoder takes the new speed now, not at its next edge */
  avr_cycle_timer_cancel(a, encoder_tick, NULL);
  enc_frac = 0;
  avr_cycle_timer_register(a, 1, encoder_tick, NULL);
}

/* busy markers: 1 starts and 2 ends the work on a window, 3 and 4 the observer step, 5 and 6
 * the ripple counter's window step (acq_ripple_board.h on_window: it sets the next burst's band) */
typedef struct { int kind; avr_cycle_count_t start, cycles; } busy_t;
static busy_t* busy;
static long n_busy;
static avr_cycle_count_t busy_start[3];

static void busy_write(avr_t* a, avr_io_addr_t addr, uint8_t v, void* param) {
  (void)param;
  a->data[addr] = v;
  if (v == 1 || v == 3 || v == 5) {
    busy_start[v / 2] = a->cycle;
  } else if ((v == 2 || v == 4 || v == 6) && n_busy < MAX_BUSY) {
    busy_t* b = &busy[n_busy++];
    b->kind = v / 2;
    b->start = busy_start[v / 2 - 1];
    b->cycles = a->cycle - busy_start[v / 2 - 1];
  }
}

static void link_pin(struct avr_irq_t* irq, uint32_t value, void* param) {
  (void)irq;
  (void)param;
  unsigned char level = value ? 1 : 0;
  if (n_comp < 64) comp_cycle[n_comp++] = avr->cycle;
  if (n_edges ? edge_level[n_edges - 1] == level : level == 1) return;
  if (n_edges < MAX_EDGES) {
    edge_cycle[n_edges] = avr->cycle;
    edge_level[n_edges] = level;
    n_edges++;
  }
}

/* The encoder drives PD2 (A) and PD3 (B). simavr's port model lets a
 * pull-up (PORT bit set on an input) override an input on every PORT or DDR
 * write unless the pins are declared externally driven, so declare them. */
static void drive_encoder(int ab_bits) {
  avr_ioport_external_t ext;
  memset(&ext, 0, sizeof ext);
  ext.name = 'D';
  ext.mask = (1u << 2) | (1u << 3);
  ext.value = (unsigned)((((ab_bits >> 1) & 1) << 2) | ((ab_bits & 1) << 3));
  avr_ioctl(avr, AVR_IOCTL_IOPORT_SET_EXTERNAL('D'), &ext);
  avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('D'), 2), (ab_bits >> 1) & 1);
  avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('D'), 3), ab_bits & 1);
}

static avr_cycle_count_t encoder_tick(struct avr_t* a, avr_cycle_count_t when, void* param) {
  (void)param;
  (void)a;
  static const int ab[4] = {0, 1, 3, 2}; /* bit1 = A (PD2), bit0 = B (PD3) */
  double eps = (cur_rpm < 0 ? -cur_rpm : cur_rpm) / 60.0 * cpr; /* edges per second */
  if (eps < 0.5) return when + F_CPU / 1000; /* standing still: look again in 1 ms */
  enc_phase = (enc_phase + (cur_rpm > 0 ? 1 : 3)) & 3;
  drive_encoder(ab[enc_phase]);
  cur_edges += cur_rpm > 0 ? 1 : -1;
  enc_frac += (double)F_CPU / eps;
  avr_cycle_count_t step = (avr_cycle_count_t)enc_frac;
  enc_frac -= (double)step;
  if (step < 1) step = 1;
  return when + step;
}

static void host_byte(struct avr_irq_t* irq, uint32_t value, void* param) {
  (void)irq;
  (void)param;
  if (n_host < MAX_HOST - 1) host[n_host++] = (char)value;
  if (value != '\n') return;
  host[n_host] = 0;
  const char* line = host + host_scan;
  host_scan = n_host;
  if (line[0] == '!') {
    answers++;
    if (strncmp(line, "! end", 5) == 0) end_seen = 1;
  } else if (line[0] == 't' && strncmp(line, "t_s,", 4) == 0) {
    header_seen = 1;
    rows_seen = 0;
  } else if (header_seen && line[0] != '#' && line[0] != '~') { /* '~': a ripple chunk, not a row */
    rows_seen++;
  }
}

static void send_line(const char* s) {
  avr_irq_t* in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
  for (; *s; ++s) avr_raise_irq(in, (uint8_t)*s);
  avr_raise_irq(in, '\n');
}

/* Decodes 8N1 bytes from the recorded pin edges, sampling mid-bit. */
static long decode_link(unsigned char* out, long cap, long* framing_errors) {
  long n = 0, e = 0;
  *framing_errors = 0;
  while (e < n_edges) {
    if (edge_level[e] != 0) { e++; continue; }
    avr_cycle_count_t start = edge_cycle[e];
    int bits[10];
    for (int k = 0; k < 10; ++k) {
      avr_cycle_count_t t = start + (avr_cycle_count_t)((k + 0.5) * link_bit_cycles);
      long j = e;
      while (j + 1 < n_edges && edge_cycle[j + 1] <= t) j++;
      bits[k] = edge_level[j];
    }
    if (start + (avr_cycle_count_t)(10 * link_bit_cycles) > avr->cycle) break; /* cut off by the end of the run */
    if (bits[0] != 0 || bits[9] != 1) (*framing_errors)++;
    unsigned char b = 0;
    for (int k = 0; k < 8; ++k) b |= (unsigned char)(bits[k + 1] << k);
    if (n < cap) out[n++] = b;
    avr_cycle_count_t stop_mid = start + (avr_cycle_count_t)(9.5 * link_bit_cycles);
    while (e < n_edges && edge_cycle[e] <= stop_mid) e++;
  }
  return n;
}

static int load_drive(const char* path) {
  FILE* f = fopen(path, "r");
  if (!f) return -1;
  char line[256];
  while (fgets(line, sizeof line, f) && n_drive < MAX_ROWS) {
    drive_row_t r;
    if (sscanf(line, "%lf,%lf,%lf", &r.v_V, &r.i_A, &r.rpm) == 3) drive[n_drive++] = r;
  }
  fclose(f);
  return n_drive ? 0 : -1;
}

int main(int argc, char** argv) {
  if (argc < 6) {
    fprintf(stderr, "usage: %s elf drive.csv outdir windows command...\n", argv[0]);
    return 2;
  }
  const char* outdir = argv[3];
  const int want_rows = atoi(argv[4]);
  char** commands = argv + 5;
  const int n_commands = argc - 5;
  if (load_drive(argv[2])) {
    fprintf(stderr, "uno_sim: cannot read %s\n", argv[2]);
    return 2;
  }
  windows = calloc(MAX_WINDOWS, sizeof *windows);
  edge_cycle = calloc(MAX_EDGES, sizeof *edge_cycle);
  edge_level = calloc(MAX_EDGES, 1);
  host = calloc(MAX_HOST, 1);
  busy = calloc(MAX_BUSY, sizeof *busy);

  elf_firmware_t fw;
  memset(&fw, 0, sizeof fw);
  if (elf_read_firmware(argv[1], &fw)) {
    fprintf(stderr, "uno_sim: cannot read %s\n", argv[1]);
    return 2;
  }
  avr = avr_make_mcu_by_name("atmega328p");
  if (!avr) return 2;
  avr_init(avr);
  avr->frequency = F_CPU;
  avr->vcc = avr->avcc = 5000;
  avr->aref = 5000;
  avr_load_firmware(avr, &fw);
  avr->frequency = F_CPU;
  avr->log = LOG_ERROR;

  uint32_t flags = 0;
  avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
  flags &= ~AVR_UART_FLAG_STDIO;
  avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
  avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), host_byte, NULL);
  /* OC2A overrides PORTB3 on the chip, but simavr's port model re-raises the
   * PORT bit of every output pin on each PORTB write: follow the timer's
   * compare output itself, which is what the pin carries on hardware. */
  avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_TIMER_GETIRQ('2'), TIMER_IRQ_OUT_COMP + AVR_TIMER_COMPA),
                          link_pin, NULL);
  avr_register_io_write(avr, GPIOR0_ADDR, marker_write, NULL);
  avr_register_io_write(avr, GPIOR1_ADDR, busy_write, NULL);
  if (adc_isr_init()) {
    fprintf(stderr, "uno_sim: no ADC interrupt irq\n");
    return 2;
  }
  if (rip_init(0x100u + fw.datasize + fw.bsssize)) {
    fprintf(stderr, "uno_sim: bad ripple feed %s or no interrupt irqs\n", getenv("UNO_SIM_RIPPLE"));
    return 2;
  }
  drive_encoder(0);
  set_inputs(0);
  avr_cycle_timer_register(avr, F_CPU / 1000, encoder_tick, NULL);

  const avr_cycle_count_t limit = (avr_cycle_count_t)F_CPU * 120; /* 2 min simulated at most */
  int sent = 0, waiting_answer = 0, answers_before = 0;
  avr_cycle_count_t done_at = 0;
  int state = cpu_Running;
  while (state != cpu_Done && state != cpu_Crashed && avr->cycle < limit) {
    state = avr_run(avr);
    rip_step();
    if (!waiting_answer && sent < n_commands && answers > 0) {
      answers_before = answers;
      send_line(commands[sent++]);
      waiting_answer = 1;
    } else if (waiting_answer && (answers > answers_before || header_seen)) {
      waiting_answer = 0;
    }
    if (!done_at && sent == n_commands && (end_seen || (header_seen && rows_seen >= want_rows)))
      done_at = avr->cycle + F_CPU / 20; /* let the last frame and line finish */
    if (done_at && avr->cycle >= done_at) break;
  }
  if (state == cpu_Crashed) {
    fprintf(stderr, "uno_sim: the firmware crashed at cycle %llu\n", (unsigned long long)avr->cycle);
    return 1;
  }

  char path[1024];
  snprintf(path, sizeof path, "%s/host.txt", outdir);
  FILE* f = fopen(path, "wb");
  if (!f) return 2;
  fwrite(host, 1, (size_t)n_host, f);
  fclose(f);

  unsigned char* link = malloc(MAX_EDGES / 2 + 1);
  long framing = 0;
  if (n_comp > 1) link_bit_cycles = (double)(comp_cycle[n_comp - 1] - comp_cycle[0]) / (double)(n_comp - 1);
  long n_link = decode_link(link, MAX_EDGES / 2, &framing);
  snprintf(path, sizeof path, "%s/link.bin", outdir);
  f = fopen(path, "wb");
  if (!f) return 2;
  fwrite(link, 1, (size_t)n_link, f);
  fclose(f);

  snprintf(path, sizeof path, "%s/windows.csv", outdir);
  f = fopen(path, "w");
  if (!f) return 2;
  fprintf(f, "seq,close_cycle,pin_v_mV,pin_i_mV,rpm_drive,edges\n");
  for (long k = 0; k < n_windows; ++k) {
    const window_t* w = &windows[k];
    fprintf(f, "%ld,%llu,%u,%u,%.6f,%ld\n", w->seq, (unsigned long long)w->close, w->v_mV, w->i_mV,
            w->rpm, w->edges);
  }
  fclose(f);
  snprintf(path, sizeof path, "%s/busy.csv", outdir);
  f = fopen(path, "w");
  if (!f) return 2;
  fprintf(f, "kind,start_cycle,cycles\n");
  for (long k = 0; k < n_busy; ++k)
    fprintf(f, "%s,%llu,%llu\n", busy[k].kind == 1 ? "window" : busy[k].kind == 2 ? "observer" : "ripple",
            (unsigned long long)busy[k].start,
            (unsigned long long)busy[k].cycles);
  fclose(f);
  if (rip_write(outdir) || adc_isr_write(outdir)) return 2;
  printf("uno_sim: %.3f s simulated, %ld windows, %d log rows, %ld link bytes (%ld framing errors), "
         "%d marker errors, link bit %.2f cycles\n",
         (double)avr->cycle / F_CPU, n_windows, rows_seen, n_link, framing, seq_errors, link_bit_cycles);
  if (!header_seen || rows_seen < want_rows) {
    fprintf(stderr, "uno_sim: only %d of %d rows arrived\n", rows_seen, want_rows);
    return 1;
  }
  return (seq_errors || framing) ? 1 : 0;
}
