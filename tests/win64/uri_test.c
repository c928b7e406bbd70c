/* pendfmu/csrc/framework/uri.c on its own, for tests/test_win64.py: built natively and with
 * mingw-w64 (run under wine), fed the same cases on stdin.
 *
 * The first output line names the platform's own path style ("local P" or "local W").
 * Then for each input line "<P|W> <buffer size> <uri>" one line: the path, or "false". */
#include <stdio.h>
#include <string.h>

#include "uri.h"

int main(void) {
    char line[1024], path[1024];
    printf("local %c\n", LOCAL_PATHS == PATHS_WINDOWS ? 'W' : 'P');
    while (fgets(line, sizeof line, stdin)) {
        line[strcspn(line, "\r\n")] = 0;
        char style;
        unsigned size;
        int uri_at = 0;
        if (sscanf(line, "%c %u %n", &style, &size, &uri_at) != 2 || !uri_at || size > sizeof path) {
            fprintf(stderr, "bad case line: %s\n", line);
            return 2;
        }
        const PathStyle paths = style == 'W' ? PATHS_WINDOWS : PATHS_POSIX;
        if (file_uri_to_path(line + uri_at, paths, path, size)) printf("%s\n", path);
        else printf("false\n");
    }
    return 0;
}
