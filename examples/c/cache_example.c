/* The smallest use of the impostor cache from C: open a cache, get one
 * result by cache key (downloaded the first time, from disk afterwards),
 * print where its files are, release it.
 *
 *   impostor_c_example SERVER CACHE_DIR KEY
 *
 * Exit status 0 when the result is available, 1 otherwise (the reason is
 * printed: status name and message). */
#include <stdio.h>

#include "impostor/impostor_c.h"

int main(int argc, char** argv) {
  if (argc != 4) {
    fprintf(stderr, "usage: %s SERVER CACHE_DIR KEY\n", argv[0]);
    return 2;
  }
  impostor_cache_options options;
  impostor_cache_options_init(&options);
  options.server = argv[1];
  options.dir = argv[2];

  impostor_cache* cache = NULL;
  impostor_status status = impostor_cache_open(&options, &cache);
  if (status != IMPOSTOR_OK) {
    printf("open %s: %s: %s\n", argv[2], impostor_status_name(status), impostor_last_error());
    return 1;
  }

  impostor_result* result = NULL;
  status = impostor_cache_get(cache, argv[3], &result);
  if (status != IMPOSTOR_OK) {
    printf("get %s: %s: %s\n", argv[3], impostor_status_name(status), impostor_last_error());
    impostor_cache_close(cache);
    return 1;
  }
  printf("%s: %s, %lld bytes in %s\n", impostor_result_key(result),
         impostor_result_downloaded(result) ? "downloaded" : "from disk",
         (long long)impostor_result_size_bytes(result), impostor_result_dir(result));
  for (size_t i = 0; i < impostor_result_file_count(result); ++i) {
    printf("  %-13s %s\n", impostor_result_file_semantic(result, i), impostor_result_file_path(result, i));
  }
  printf("albedo map: %s\n", impostor_result_map_path(result, "albedo_alpha"));

  impostor_result_release(result); /* unpins it: eviction may now remove it */
  impostor_cache_close(cache);
  return 0;
}
