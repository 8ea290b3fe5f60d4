#include "client/cli/bake_settings.h"

namespace impostor::cli {

sdk::BakeSettings BakeSettingsFromArgs(const CliArgs& args) {
  sdk::BakeSettings s;
  s.layout = args.layout;
  s.ring_views = args.ring_views;
  s.supersampling = args.supersampling;
  s.frames = args.frames;
  s.resolution = args.resolution;
  s.product = args.product;
  s.preset = args.preset;
  s.point_budget = args.point_budget;
  s.max_planes = args.max_planes;
  s.tolerance = args.tolerance;
  s.priority = args.priority.value_or(0);
  s.required_tags = args.required_tags;
  s.lod_ratios = args.lod_ratios;
  s.lod_pixel_error = args.lod_pixel_error;
  s.min_iou = args.min_iou;
  s.min_psnr_db = args.min_psnr_db;
  s.frames_auto = args.frames_auto;
  s.quality_views = args.quality_views;
  s.emissive = args.emissive;
  s.texture_array = args.texture_array;
  s.texture_format = args.texture_format;
  s.albedo_codec = args.albedo_codec;
  s.follow_symlinks = args.follow_symlinks;
  return s;
}

}  // namespace impostor::cli
