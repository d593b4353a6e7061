// Reset stub of the lx106 benchmark (lx106_step.cpp): QEMU's sim machine starts at
// 0x50000000; set the stack at the top of the data RAM and call lx106_main.
    .section .reset.text, "ax"
    .global _reset
    .align 4
_reset:
    j 2f
    .align 4
1:  .word 0x3fffff00
    .word lx106_main
2:  l32r a1, 1b
    l32r a0, 1b + 4
    callx0 a0
3:  j 3b
