/* cmd_scene.c -- `raytraffic scene` (not yet implemented). */
#include "cmd.h"

#include <stdio.h>
#include <string.h>

int main_scene(int argc, char **argv)
{
    if (argc > 1 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
        printf("Usage: raytraffic scene (not yet implemented)\n");
        return RT_EXIT_OK;
    }
    rt_cmd_error("scene", "not yet implemented");
    return RT_EXIT_FAIL;
}
