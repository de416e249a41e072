/*
 * A stand-in bcryptprimitives.dll for wine 8, which lacks it: Rust's standard library imports
 * ProcessPrng from it (present on Windows 10 and later), so our win64 FMU libraries do not load
 * under Debian 12's wine without it. The test puts this DLL beside fmu_harness.exe only; it is
 * never shipped. ProcessPrng fills the buffer from RtlGenRandom (advapi32's SystemFunction036).
 */
#include <windows.h>

BOOLEAN WINAPI SystemFunction036(PVOID buffer, ULONG length);

__declspec(dllexport) BOOL WINAPI ProcessPrng(PBYTE data, SIZE_T length) {
    while (length > 0) {
        ULONG chunk = length > 0x10000000 ? 0x10000000 : (ULONG)length;
        if (!SystemFunction036(data, chunk)) return FALSE;
        data += chunk;
        length -= chunk;
    }
    return TRUE;
}
