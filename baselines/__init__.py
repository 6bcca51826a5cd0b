"""Classical planners for the IOS-aided UAV problem: SCA (the paper), DP (global optimum), fixed."""
