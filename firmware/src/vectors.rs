//! The STM32F405's interrupt vectors: its 82 IRQ lines (RM0090 table 61, WWDG … FPU), every
//! one on cortex-m-rt's `DefaultHandler`. Without a device crate cortex-m-rt reserves the
//! architecture's 240 lines (960 bytes of flash); this table holds 328. The firmware enables
//! no device interrupt (the preflight polls; SysTick is a core exception).

/// IRQ lines of the STM32F405/407 (the last is 81, FPU).
const IRQ_LINES: usize = 82;

extern "C" {
    fn DefaultHandler();
}

/// One vector: a handler (reserved slots of the F405 also point at `DefaultHandler`, which is
/// never reached since no line is enabled).
#[repr(transparent)]
pub struct Vector(unsafe extern "C" fn());

#[link_section = ".vector_table.interrupts"]
#[no_mangle]
#[used]
pub static __INTERRUPTS: [Vector; IRQ_LINES] = [const { Vector(DefaultHandler) }; IRQ_LINES];
