// Standalone node wrapping gyro_allan/AnalyzerNodelet (same topics and parameters, no nodelet manager needed).
#include <nodelet/loader.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "gyro_allan_analyzer");
  nodelet::Loader loader(false);  // no manager services, no bond: this process owns the nodelet
  const nodelet::M_string remappings(ros::names::getRemappings());
  const nodelet::V_string my_argv(argv + 1, argv + argc);
  if (!loader.load(ros::this_node::getName(), "gyro_allan/AnalyzerNodelet", remappings, my_argv)) {
    ROS_FATAL("could not load gyro_allan/AnalyzerNodelet (is the package built and sourced?)");
    return 1;
  }
  ros::spin();
  return 0;
}
