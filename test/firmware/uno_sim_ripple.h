/*
 * The ripple mode in the harness (issue 23; uno_acq built with -DACQ_RIPPLE_HZ), included by
 * uno_sim.c. On when the environment variable UNO_SIM_RIPPLE names a feed file: one line
 * per window (window k uses line k mod the number of lines, as the drive table), the
 * current channel's pin voltage in mV in each PWM period of the window, space separated
 * (value j for a conversion triggered in the window's period j; the last value repeats for
 * later periods).
 *
 * simavr 1.6 does not implement the ADC's auto trigger from a timer (its avr_adc.c logs
 * "unimplemented auto trigger mode" and ignores ADTS). The harness does what the chip does:
 * the trigger is the rising edge of OCF1B (Timer1 compare match B); when ADCSRA has ADATE
 * and ADCSRB's ADTS is 101 (compare match B) it raises the ADC's trigger input, which starts
 * a conversion unless one is running. A compare match whose flag was not cleared since the
 * last one is no edge and starts nothing (counted), like one that meets a running
 * conversion (counted). At each triggered conversion's start the harness sets A1 to the next
 * feed value (simavr reads the input when ADCL is read, which in the firmware happens in the
 * conversion's own interrupt); a free-running conversion of A1 gets the window's current.
 *
 * Writes <out>/ripple_triggers.csv: per triggered conversion its index, the cycle of the
 * compare match, the cycle of the period's start (the last TOV1), whether the ADC started
 * (1; 0 when it was converting; -1 when the flag was still set, no edge),
 * the fed mV and code; and
 * <out>/ripple_reads.csv: every read of the ADC's result (ADCL, which the firmware reads in an
 * atomic section with the window's bank), its cycle, the 10-bit code, ADMUX's channel bit and
 * ADATE at the read: with the window closes, which window's V or I sum each code went into
 * (check_uno_ripple.py's exact V/I means).
 *
 * The coast probe (-DACQ_COAST=1, acq_coast.h) converts the terminal voltage (A0) and the current
 * (A1) in turn on the trigger: a triggered conversion of A0 gets the feed value as A0's input, one
 * of A1 as A1's; ripple_triggers.csv gives each triggered conversion's channel (ch). And
 * <out>/ripple_pwm.csv: at each Timer1 overflow (the period's end) the PWM's state the firmware set
 * for that period: OCR1A (in force from the next period: double-buffered), TCCR1A and PORTB, from
 * which check_uno_coast.py measures how long the drive is held off; <out>/ovf_isr.csv: each Timer1
 * overflow interrupt's entry cycle and cycles until reti (the probe's work is in it).
 */
#ifndef UNO_SIM_RIPPLE_H
#define UNO_SIM_RIPPLE_H

#define RIP_ADCSRA 0x7A
#define RIP_ADCSRB 0x7B
#define RIP_ADATE 5
#define RIP_VEC_T1_COMPB 12
#define RIP_VEC_T1_OVF 13
#define RIP_VEC_ADC 21
#define RIP_MAX 4000000

typedef struct {
  avr_cycle_count_t trig, period_start;
  unsigned mv;
  int started;
  unsigned ocr1a, ocr1b; /* in force at the match */
  int ch;                /* the channel converted (ADMUX's MUX0 at the start), -1 when none started */
} rip_trig_t;

typedef struct {
  avr_cycle_count_t cycle;
  unsigned ocr1a, tccr1a, portb;
} rip_pwm_t;
static rip_pwm_t* rip_pwm;
static long rip_n_pwm;

typedef struct {
  avr_cycle_count_t entry, cycles;
  int triggered;
} rip_isr_t;
static rip_isr_t* rip_ovf_isr;
static long rip_n_ovf_isr;
static avr_cycle_count_t rip_ovf_entry;  /* Timer1's overflow interrupts (ovf_isr.csv) */

static int rip_on;
static unsigned** rip_feed; /* per window line */
static long* rip_feed_len;
static long rip_n_feed;

static rip_trig_t* rip_trig;
static long rip_n_trig;
static rip_isr_t* rip_isr;
static long rip_n_isr;
static int rip_flag;         /* OCF1B as last notified */
static int rip_arming;       /* the harness raised the ADC trigger input just now */
static long rip_no_edge;     /* compare matches with ADATE set while the flag was still set */
static avr_cycle_count_t rip_period_start;
static int rip_isr_depth;
static avr_cycle_count_t rip_isr_entry;
static int rip_isr_triggered;
static unsigned rip_cur_i_mV; /* the window's current, for free-running conversions of A1 */
typedef struct {
  avr_cycle_count_t cycle;
  unsigned code;
  int channel, adate;
} rip_read_t;
static rip_read_t* rip_read;
static long rip_n_read;
#define RIP_ADCL 0x78
#define RIP_ADCH 0x79
#define RIP_ADMUX 0x7C
static avr_io_read_t rip_adcl_orig; /* simavr's ADCL read (it converts there) */
static void* rip_adcl_orig_param;

/* ADCL is read: simavr's own read converts, then the code, channel and ADATE are recorded. */
static uint8_t rip_adcl_read(struct avr_t* a, avr_io_addr_t addr, void* param) {
  (void)param;
  const uint8_t lo = rip_adcl_orig(a, addr, rip_adcl_orig_param);
  if (rip_n_read < RIP_MAX) {
    rip_read_t* r = &rip_read[rip_n_read++];
    r->cycle = a->cycle;
    r->code = lo | ((unsigned)(a->data[RIP_ADCH] & 3u) << 8);
    r->channel = a->data[RIP_ADMUX] & 1;
    r->adate = (a->data[RIP_ADCSRA] >> RIP_ADATE) & 1;
  }
  return lo;
}

static unsigned rip_sp_min = 0xFFFF; /* the stack pointer's low-water mark (rip_step) */
static unsigned rip_ram_end;          /* first address above .data and .bss */

/* The instruction at flash byte address pc: OUT to I/O address io (0x3D SPL, 0x3F SREG)? */
static int rip_is_out(unsigned pc, unsigned io) {
  if (pc + 1 > avr->flashend) return 0;
  const unsigned op = avr->flash[pc] | (avr->flash[pc + 1] << 8);
  return (op & 0xFE0Fu) == (0xB800u | ((io & 0x30u) << 5) | (io & 0x0Fu));
}

/* After each instruction: the stack's low-water mark. A frame's prologue and epilogue write
 * SPH, then SREG, then SPL (avr-gcc: out 0x3e; out 0x3f; out 0x3d): between the first and the
 * last the SP register holds the new high byte beside the old low byte, up to 255 bytes off
 * where the frame crosses a 256-byte page. Not sampled there (it once read 229 bytes low). */
static void rip_step(void) {
  if (!rip_on) return;
  if (rip_is_out(avr->pc, 0x3D) || (rip_is_out(avr->pc, 0x3F) && rip_is_out(avr->pc + 2, 0x3D))) return;
  const unsigned sp = avr->data[0x5D] | (avr->data[0x5E] << 8);
  if (sp < rip_sp_min) rip_sp_min = sp;
}

static void rip_compb(struct avr_irq_t* irq, uint32_t value, void* param) {
  (void)irq;
  (void)param;
  const int rising = value && !rip_flag;
  rip_flag = value ? 1 : 0;
  if (!value) return;
  const int adate = (avr->data[RIP_ADCSRA] >> RIP_ADATE) & 1;
  const int adts = avr->data[RIP_ADCSRB] & 7;
  if (!adate || adts != 5) return;
  if (rip_n_trig >= RIP_MAX) return;
  rip_trig_t* t = &rip_trig[rip_n_trig++];
  t->trig = avr->cycle;
  t->period_start = rip_period_start;
  t->mv = 0;
  t->started = rising ? 0 : -1; /* -1: the flag was still set, no edge: no conversion */
  t->ocr1a = avr->data[0x88] | (avr->data[0x89] << 8);
  t->ocr1b = avr->data[0x8A] | (avr->data[0x8B] << 8);
  t->ch = -1;
  if (!rising) {
    rip_no_edge++;
    return;
  }
  rip_arming = 1;
  avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_IN_TRIGGER), 1);
  avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_IN_TRIGGER), 0);
  rip_arming = 0;
}

static void rip_ovf(struct avr_irq_t* irq, uint32_t value, void* param) {
  (void)irq;
  (void)param;
  if (!value) return;
  rip_period_start = avr->cycle;
  if (rip_pwm && rip_n_pwm < RIP_MAX) {
    rip_pwm_t* r = &rip_pwm[rip_n_pwm++];
    r->cycle = avr->cycle;
    r->ocr1a = avr->data[0x88] | (avr->data[0x89] << 8);
    r->tccr1a = avr->data[0x80];
    r->portb = avr->data[0x25];
  }
}

/* A conversion starts: value is the avr_adc_mux_t of the channel. */
static void rip_adc_start(struct avr_irq_t* irq, uint32_t value, void* param) {
  (void)irq;
  (void)param;
  union {
    avr_adc_mux_t mux;
    uint32_t v;
  } e;
  e.v = value;
  if (rip_arming && rip_n_trig > 0) {
    rip_trig_t* t = &rip_trig[rip_n_trig - 1];
    t->started = 1;
    /* the open window (uno_sim.c: window n_windows, opened at the last close) and its period */
    const avr_cycle_count_t open = n_windows ? windows[n_windows - 1].close : 0;
    const unsigned period = (avr->data[0x86] | (avr->data[0x87] << 8)) + 1u; /* ICR1 + 1 */
    const long w = n_windows % rip_n_feed;
    /* the period of the window: its start (the last TOV1) counted from the window's close, to
       the nearest period, as check_uno_ripple.py counts it: the close's marker is written a
       little after the period boundary the firmware closes on (the main loop's latency, tens to
       hundreds of cycles, which moves with the code's layout), so the trigger's own cycle
       counted from the marker falls a period short whenever that latency exceeds the compare
       match's offset in its period */
    const long long since = (long long)t->period_start - (long long)open;
    long j = since <= 0 ? 0 : (long)((since + period / 2) / period);
    if (j >= rip_feed_len[w]) j = rip_feed_len[w] - 1;
    t->mv = rip_feed[w][j];
    t->ch = e.mux.src == 0 ? 0 : 1; /* a coast probe's voltage sample converts A0 */
    avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, t->ch ? ADC_IRQ_ADC1 : ADC_IRQ_ADC0), t->mv);
  } else if (e.mux.src == 1) {
    avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC1), rip_cur_i_mV);
  }
}

static void rip_adc_running(struct avr_irq_t* irq, uint32_t value, void* param) {
  (void)irq;
  (void)param;
  if (value) {
    if (rip_isr_depth++ == 0) {
      rip_isr_entry = avr->cycle;
      rip_isr_triggered = (avr->data[RIP_ADCSRA] >> RIP_ADATE) & 1;
    }
  } else if (rip_isr_depth > 0 && --rip_isr_depth == 0 && rip_n_isr < RIP_MAX) {
    rip_isr_t* r = &rip_isr[rip_n_isr++];
    r->entry = rip_isr_entry;
    r->cycles = avr->cycle - rip_isr_entry;
    r->triggered = rip_isr_triggered;
  }
}

/* Timer1's overflow interrupt runs (value 1) or returns (0); not interruptible (no nesting). */
static void rip_ovf_running(struct avr_irq_t* irq, uint32_t value, void* param) {
  (void)irq;
  (void)param;
  if (value) {
    rip_ovf_entry = avr->cycle;
  } else if (rip_ovf_isr && rip_n_ovf_isr < RIP_MAX) {
    rip_ovf_isr[rip_n_ovf_isr].entry = rip_ovf_entry;
    rip_ovf_isr[rip_n_ovf_isr].cycles = avr->cycle - rip_ovf_entry;
    rip_ovf_isr[rip_n_ovf_isr++].triggered = 0;
  }
}

/* The interrupt vector's irq: index 0 is raised with the flag, 1 while its routine runs. */
static avr_irq_t* rip_vector_irq(int vector, int which) {
  avr_irq_t* irq = avr_get_interrupt_irq(avr, (uint8_t)vector);
  return irq ? irq + which : NULL;
}

/* Called once the firmware is loaded (ram_end: SRAM start + .data + .bss); -1 on a bad feed file. */
static int rip_init(unsigned ram_end) {
  rip_ram_end = ram_end;
  const char* path = getenv("UNO_SIM_RIPPLE");
  if (!path || !*path) return 0;
  FILE* f = fopen(path, "r");
  if (!f) return -1;
  rip_feed = calloc(MAX_ROWS, sizeof *rip_feed);
  rip_feed_len = calloc(MAX_ROWS, sizeof *rip_feed_len);
  char* line = NULL;
  size_t cap = 0;
  while (rip_n_feed < MAX_ROWS && getline(&line, &cap, f) > 0) {
    long n = 0, room = 64;
    unsigned* v = malloc((size_t)room * sizeof *v);
    char* p = line;
    char* end;
    for (;;) {
      unsigned long x = strtoul(p, &end, 10);
      if (end == p) break;
      if (n == room) v = realloc(v, (size_t)(room *= 2) * sizeof *v);
      v[n++] = (unsigned)x;
      p = end;
    }
    if (!n) break;
    rip_feed[rip_n_feed] = v;
    rip_feed_len[rip_n_feed++] = n;
  }
  free(line);
  fclose(f);
  if (!rip_n_feed) return -1;
  rip_trig = calloc(RIP_MAX, sizeof *rip_trig);
  rip_read = calloc(RIP_MAX, sizeof *rip_read);
  rip_pwm = calloc(RIP_MAX, sizeof *rip_pwm);
  rip_on = 1;
  /* Chained by hand: avr_register_io_read refuses a second callback on an address. */
  rip_adcl_orig = avr->io[AVR_DATA_TO_IO(RIP_ADCL)].r.c;
  rip_adcl_orig_param = avr->io[AVR_DATA_TO_IO(RIP_ADCL)].r.param;
  if (!rip_adcl_orig) return -1;
  avr->io[AVR_DATA_TO_IO(RIP_ADCL)].r.c = rip_adcl_read;
  avr->io[AVR_DATA_TO_IO(RIP_ADCL)].r.param = NULL;
  avr_irq_t* compb = rip_vector_irq(RIP_VEC_T1_COMPB, AVR_INT_IRQ_PENDING);
  avr_irq_t* ovf = rip_vector_irq(RIP_VEC_T1_OVF, AVR_INT_IRQ_PENDING);
  if (!compb || !ovf) return -1;
  avr_irq_register_notify(compb, rip_compb, NULL);
  avr_irq_register_notify(ovf, rip_ovf, NULL);
  rip_ovf_isr = calloc(RIP_MAX, sizeof *rip_ovf_isr);
  avr_irq_t* ovf_run = rip_vector_irq(RIP_VEC_T1_OVF, AVR_INT_IRQ_RUNNING);
  if (!rip_ovf_isr || !ovf_run) return -1;
  avr_irq_register_notify(ovf_run, rip_ovf_running, NULL);
  avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_OUT_TRIGGER), rip_adc_start, NULL);
  return 0;
}

static int rip_write(const char* outdir) {
  if (!rip_on) return 0;
  char path[1024];
  snprintf(path, sizeof path, "%s/ripple_triggers.csv", outdir);
  FILE* f = fopen(path, "w");
  if (!f) return -1;
  fprintf(f, "k,trig_cycle,period_start,started,mv,code,ocr1a,ocr1b,ch\n");
  for (long k = 0; k < rip_n_trig; ++k) {
    const rip_trig_t* t = &rip_trig[k];
    /* simavr's scale (avr_adc.c): code = mV * 1023 / AVcc mV, truncated */
    fprintf(f, "%ld,%llu,%llu,%d,%u,%u,%u,%u,%d\n", k, (unsigned long long)t->trig, (unsigned long long)t->period_start,
            t->started, t->mv, t->mv * 1023u / 5000u, t->ocr1a, t->ocr1b, t->ch);
  }
  fclose(f);
  snprintf(path, sizeof path, "%s/ripple_pwm.csv", outdir);
  f = fopen(path, "w");
  if (!f) return -1;
  fprintf(f, "cycle,ocr1a,tccr1a,portb\n");
  for (long k = 0; k < rip_n_pwm; ++k)
    fprintf(f, "%llu,%u,%u,%u\n", (unsigned long long)rip_pwm[k].cycle, rip_pwm[k].ocr1a, rip_pwm[k].tccr1a,
            rip_pwm[k].portb);
  fclose(f);
  snprintf(path, sizeof path, "%s/ovf_isr.csv", outdir);
  f = fopen(path, "w");
  if (!f) return -1;
  fprintf(f, "entry_cycle,cycles\n");
  for (long k = 0; k < rip_n_ovf_isr; ++k)
    fprintf(f, "%llu,%llu\n", (unsigned long long)rip_ovf_isr[k].entry, (unsigned long long)rip_ovf_isr[k].cycles);
  fclose(f);
  snprintf(path, sizeof path, "%s/ripple_reads.csv", outdir);
  f = fopen(path, "w");
  if (!f) return -1;
  fprintf(f, "cycle,code,channel,adate\n");
  for (long k = 0; k < rip_n_read; ++k)
    fprintf(f, "%llu,%u,%d,%d\n", (unsigned long long)rip_read[k].cycle, rip_read[k].code, rip_read[k].channel,
            rip_read[k].adate);
  fclose(f);
  const char* peek = getenv("UNO_SIM_PEEK"); /* a data address to print at the end (the ring's peak) */
  if (peek && *peek) {
    const unsigned long addr = strtoul(peek, NULL, 0);
    if (addr < 0x900) printf("uno_sim ripple: peek 0x%04lX = %u\n", addr, avr->data[addr]);
  }
  printf("uno_sim ripple: %ld triggers, %ld compare matches without an edge, %ld ADC interrupts, "
         "stack low-water SP 0x%04X (%u bytes above the static RAM's end 0x%04X)\n",
         rip_n_trig, rip_no_edge, rip_n_isr, rip_sp_min, rip_sp_min - rip_ram_end, rip_ram_end);
  return 0;
}

/* Every build, not only the ripple mode's: <out>/adc_isr.csv, per ADC interrupt its entry
 * cycle and cycles until reti (nested interrupts included), and whether ADATE was set at entry
 * (a triggered conversion's): the ADC interrupt's share of the CPU (check_uno_sim.py,
 * check_uno_ripple.py, hpddo bench --observer). */
static int adc_isr_init(void) {
  rip_isr = calloc(RIP_MAX, sizeof *rip_isr);
  avr_irq_t* adc_run = rip_vector_irq(RIP_VEC_ADC, AVR_INT_IRQ_RUNNING);
  if (!rip_isr || !adc_run) return -1;
  avr_irq_register_notify(adc_run, rip_adc_running, NULL);
  return 0;
}

static int adc_isr_write(const char* outdir) {
  char path[1024];
  snprintf(path, sizeof path, "%s/adc_isr.csv", outdir);
  FILE* f = fopen(path, "w");
  if (!f) return -1;
  fprintf(f, "entry_cycle,cycles,triggered\n");
  for (long k = 0; k < rip_n_isr; ++k)
    fprintf(f, "%llu,%llu,%d\n", (unsigned long long)rip_isr[k].entry, (unsigned long long)rip_isr[k].cycles,
            rip_isr[k].triggered);
  fclose(f);
  return 0;
}

#endif /* UNO_SIM_RIPPLE_H */
