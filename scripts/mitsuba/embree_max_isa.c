/* Preloaded into Mitsuba's Python (scripts/mitsuba/as-avx2.sh): appends the Embree device
 * options of RTDIFF_EMBREE_CONFIG (e.g. "max_isa=avx2") to the configuration string Mitsuba
 * passes to rtcNewDevice, so that Embree inside Mitsuba runs the kernels of a CPU without
 * AVX-512. Mitsuba's Embree 3 is built in the namespace `mitsuba` (hence the C++ symbol). */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>

typedef void *(*new_device_fn)(const char *);

void *_ZN7mitsuba12rtcNewDeviceEPKc(const char *config) {
    void *lib = dlopen("libembree3.so", RTLD_LAZY | RTLD_NOLOAD);
    new_device_fn real = lib ? (new_device_fn) dlsym(lib, "_ZN7mitsuba12rtcNewDeviceEPKc") : NULL;
    if (!real || (void *) real == (void *) _ZN7mitsuba12rtcNewDeviceEPKc) {
        fprintf(stderr, "embree_max_isa: Mitsuba's libembree3.so is not loaded\n");
        abort();
    }
    const char *extra = getenv("RTDIFF_EMBREE_CONFIG");
    char buf[1024];
    snprintf(buf, sizeof buf, "%s%s%s", config ? config : "", (config && *config && extra) ? "," : "",
             extra ? extra : "");
    fprintf(stderr, "embree_max_isa: rtcNewDevice(\"%s\")\n", buf);
    return real(buf);
}
