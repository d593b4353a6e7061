/* avr-libc's float against IEEE single rounded to nearest, on the ATmega328P in simavr: prints the
   bits of a+b, a*b, a/b (operands of a few decades around 1, either sign) and of expf(x), x in
   [-10, 0], for a fixed integer sequence of operands, one line each; float_check.py builds and runs
   this and compares on the host (docs/firmware.md, "The dynamic family on the UNO"). */
#include <math.h>
#include <stdint.h>
#include <string.h>
void hpddo_unity_putchar(int c);
void hpddo_unity_done(void);
static uint32_t st = 12345u;
static uint32_t rnd(void) { st = st * 1103515245u + 12345u; return st; }
static void hex(uint32_t u) { for (int k = 28; k >= 0; k -= 4) hpddo_unity_putchar("0123456789abcdef"[(u >> k) & 15]); }
static uint32_t b(float f) { uint32_t u; memcpy(&u, &f, 4); return u; }
static float mk(void) { /* a float of a few decades around 1, either sign */
  uint32_t r = rnd(); uint32_t e = 127u - 8u + ((r >> 8) % 17u); uint32_t m = rnd() & 0x7FFFFFu;
  uint32_t u = ((r & 1u) << 31) | (e << 23) | m; float f; memcpy(&f, &u, 4); return f; }
int main(void) {
  for (int k = 0; k < 400; ++k) {
    volatile float a = mk(), c = mk();
    hex(b(a)); hpddo_unity_putchar(' '); hex(b(c)); hpddo_unity_putchar(' ');
    hex(b(a + c)); hpddo_unity_putchar(' '); hex(b(a * c)); hpddo_unity_putchar(' '); hex(b(a / c));
    hpddo_unity_putchar(' ');
    volatile float x = -(float)(rnd() % 100000u) * 1e-4f;  /* -10..0: the pole's -dt/tau */
    hex(b(x)); hpddo_unity_putchar(' '); hex(b(expf(x))); hpddo_unity_putchar('\n');
  }
  hpddo_unity_done();
  return 0;
}
