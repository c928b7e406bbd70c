/* The library a hostile FMU's modelIdentifier points at ("../../x/evil", or a path out of the
   FMU): loading it is enough to run its constructor, which appends a line to the file named by
   PENDFMU_EVIL_MARKER. The tests assert that file never appears. */

#include <stdio.h>
#include <stdlib.h>

__attribute__((constructor)) static void mark(void) {
    const char *marker = getenv("PENDFMU_EVIL_MARKER");
    FILE *file = marker ? fopen(marker, "a") : NULL;
    if (file) {
        fputs("the evil library was loaded\n", file);
        fclose(file);
    }
}
