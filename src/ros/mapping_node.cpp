// Standalone node wrapper of amhmvs_mapping/MappingNodelet: loads the nodelet
// into this process with the node's name, namespace, remappings and private
// parameters.
#include <nodelet/loader.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "amhmvs_mapping");
  nodelet::Loader loader(false);  // no manager services
  const nodelet::M_string remappings(ros::names::getRemappings());
  nodelet::V_string nodelet_argv(argv + 1, argv + argc);
  if (!loader.load(ros::this_node::getName(), "amhmvs_mapping/MappingNodelet", remappings, nodelet_argv)) {
    ROS_FATAL("could not load the nodelet amhmvs_mapping/MappingNodelet (is the package on ROS_PACKAGE_PATH?)");
    return 1;
  }
  ros::spin();
  return 0;
}
