function report = set_parameters(varargin)
%SET_PARAMETERS Set the values exported by pendfmu on Simulink FMU Import blocks.
%   @ABOUT@
%
%   set_parameters()                        the blocks named like the components (@COMPONENTS@)
%                                           in the current system (gcs); a component with no block
%                                           of its name: the one FMU block there that loads its FMU
%   set_parameters('Cart', 'rig/Cart FMU')  this block for component Cart (the others as above)
%   set_parameters(struct('Cart', 'rig/C')) the same, as a struct
%   set_parameters('system', 'rig/plant')   look in this system instead of gcs
%   set_parameters('mat', 'parameters.mat') take the values from the .mat file written with
%                                           this script (the same values) instead of its own
%   set_parameters('check_fmu', false)      do not compare the block's FMU with the exported one
%   report = set_parameters(...)            also return what was set: struct array with fields
%                                           component, block, parameter, value (the text set)
%
%   A block is changed only if it is an FMU Import block (BlockType 'FMU') whose FMU file (its
%   FMUName, found as given, in the current folder, beside this script or on the MATLAB path)
%   has the GUID of the exported FMU, and only if the block has a parameter for every value;
%   otherwise nothing is set on it and the reason is printed. The function ends with an error
%   naming every block it could not set.
%
%   How the block takes the values (https://www.mathworks.com/help/simulink/ref_extras/fmu.html,
%   "Parameters" tab, and https://www.mathworks.com/help/simulink/ug/work-with-fmi-in-simulink.html):
%   each parameter of the FMU is a block parameter named like the FMU variable, whose value is
%   text that MATLAB evaluates: set_param(block, name, text). Its default is the start value in
%   the FMU's modelDescription.xml (the exported FMUs carry these values there too); the block
%   value overrides it. A structured name such as a.b is a field of the struct-valued block
%   parameter a unless the block's FMUParamMapping is 'Flat'; both forms are handled here. Values
%   are written with 17 significant digits (%.17g), which read back to the same doubles.

% Name the blocks here once instead of passing them (a component named here or in an argument
% is looked for at that path only):
BLOCKS = struct();      % e.g. BLOCKS.Cart = 'rig/Cart';
CHECK_FMU = true;       % false: do not compare the block's FMU (GUID) with the exported one

here = fileparts(mfilename('fullpath'));
options = parse_arguments(BLOCKS, CHECK_FMU, varargin);
if isempty(options.mat)
    exported = exported_values();
    fprintf('set_parameters: values of %s\n', exported_source());
else
    [exported, source] = values_from_mat(options.mat, here);
    fprintf('set_parameters: values of %s, from %s\n', source, options.mat);
end
report = struct('component', {}, 'block', {}, 'parameter', {}, 'value', {});
failed = {};
skipped = {};
for k = 1:numel(exported)
    c = exported{k};
    [blk, problem] = block_of(c, options);
    if isempty(blk)
        if isempty(problem)
            skipped{end + 1} = c.component; %#ok<AGROW>
        else
            failed{end + 1} = sprintf('%s: %s', c.component, problem); %#ok<AGROW>
            fprintf('%s: NOT SET: %s\n', c.component, problem);
        end
        continue
    end
    problem = check_block(blk, c, options.check_fmu, here);
    pairs = {};
    if isempty(problem)
        [pairs, problem] = block_settings(blk, c);
    end
    if ~isempty(problem)
        failed{end + 1} = sprintf('%s (%s): %s', c.component, blk, problem); %#ok<AGROW>
        fprintf('%s: NOT SET on ''%s'': %s\n', c.component, blk, problem);
        continue
    end
    set_param(blk, pairs{:});
    fprintf('%s: set %d parameters on ''%s'' (%s):\n', c.component, numel(c.names), blk, c.fmu);
    for i = 1:numel(c.names)
        fprintf('  %s = %s%s  (%s)\n', c.names{i}, c.text{i}, unit_text(c.units{i}), c.origins{i});
        report(end + 1) = struct('component', c.component, 'block', blk, ...
                                 'parameter', c.names{i}, 'value', c.text{i}); %#ok<AGROW>
    end
end
if isempty(failed) && isempty(report)
    failed{end + 1} = sprintf('no block of this export in ''%s'' (looked for %s); name the blocks: %s', ...
                              options.system, strjoin(skipped, ', '), usage_hint(exported));
end
if ~isempty(failed)
    error('pendfmu:set_parameters', 'set_parameters: not set: %s', strjoin(failed, '; '));
end
if nargout == 0
    clear report
end
end


function options = parse_arguments(blocks, check_fmu, args)
% The options: blocks as two lists (names, paths), the system, the .mat file, the check.
options = struct('names', {{}}, 'paths', {{}}, 'system', '', 'mat', '', 'check_fmu', check_fmu);
options = add_blocks(options, blocks);
i = 1;
while i <= numel(args)
    key = args{i};
    if isstruct(key)
        options = add_blocks(options, key);
        i = i + 1;
        continue
    end
    if isa(key, 'string'), key = char(key); end
    if ~ischar(key) || i == numel(args)
        error('pendfmu:set_parameters', ['set_parameters: arguments are name/value pairs: a component ' ...
              'and its block path, ''system'', ''mat'' or ''check_fmu'' (argument %d)'], i);
    end
    value = args{i + 1};
    if isa(value, 'string'), value = char(value); end
    switch key
        case 'system'
            options.system = value;
        case 'mat'
            options.mat = value;
        case 'check_fmu'
            options.check_fmu = logical(value);
        otherwise
            options.names{end + 1} = key;
            options.paths{end + 1} = value;
    end
    i = i + 2;
end
if isempty(options.system)
    options.system = gcs;
end
end


function options = add_blocks(options, blocks)
names = fieldnames(blocks);
for i = 1:numel(names)
    options.names{end + 1} = names{i};
    options.paths{end + 1} = char(blocks.(names{i}));
end
end


function [blk, problem] = block_of(c, options)
% The block for component c: the one named for it, else its block by name in the system,
% else the only FMU block there whose FMUName is the exported FMU's file name. Neither found:
% both empty (skipped: the model may hold only some components).
blk = '';
problem = '';
given = find(strcmp(options.names, c.component), 1, 'last');
if ~isempty(given)
    blk = options.paths{given};
    return
end
if isempty(options.system)
    problem = sprintf(['no current system to look in (gcs is empty): open the model, or pass ''system'' ' ...
                       'or the block: set_parameters(''%s'', PATH)'], c.component);
    return
end
try
    named = find_system(options.system, 'SearchDepth', 1, 'Name', c.component);
    fmu_blocks = find_system(options.system, 'SearchDepth', 1, 'BlockType', 'FMU');
catch err
    problem = sprintf('cannot look in system ''%s'' (%s)', options.system, err.message);
    return
end
named = named(~strcmp(named, options.system));
if numel(named) == 1
    blk = named{1};
    return
end
[~, stem] = fileparts(c.fmu);
loading = {};
for i = 1:numel(fmu_blocks)
    [~, name] = fileparts(get_param(fmu_blocks{i}, 'FMUName'));
    if strcmp(name, stem)
        loading{end + 1} = fmu_blocks{i}; %#ok<AGROW>
    end
end
if numel(loading) == 1
    blk = loading{1};
    fprintf('%s: no block named %s in ''%s''; using ''%s'', which loads %s\n', c.component, c.component, ...
            options.system, blk, c.fmu);
elseif numel(loading) > 1
    problem = sprintf('several FMU blocks in ''%s'' load %s (%s): name one: set_parameters(''%s'', PATH)', ...
                      options.system, c.fmu, strjoin(loading, ', '), c.component);
else
    fprintf('%s: skipped: no block named %s in ''%s'', and no FMU block there loads %s\n', ...
            c.component, c.component, options.system, c.fmu);
end
end


function problem = check_block(blk, c, check_fmu, here)
% Why block blk must not receive the values of c ('' when it may).
problem = '';
try
    type = get_param(blk, 'BlockType');
catch err
    problem = sprintf('no such block (%s)', err.message);
    return
end
if ~strcmp(type, 'FMU')
    problem = sprintf('a %s block, not an FMU Import block', type);
    return
end
fmu = get_param(blk, 'FMUName');
if ~check_fmu
    return
end
file = locate_fmu(fmu, here);
if isempty(file)
    problem = sprintf(['cannot find its FMU ''%s'' (as given, beside this script or on the MATLAB path) to ' ...
                       'check that it is the exported %s (GUID %s): add its folder with addpath, or pass ' ...
                       '''check_fmu'', false'], fmu, c.fmu, c.guid);
    return
end
[guid, why] = fmu_guid(file);
if isempty(guid)
    problem = sprintf('cannot read the GUID of its FMU %s (%s)', file, why);
elseif ~strcmp(guid, c.guid)
    problem = sprintf(['its FMU %s has GUID %s, not the exported %s''s %s: another FMU or another ' ...
                       'export; load the exported %s into it (FMUName) or name the right block'], ...
                      file, guid, c.fmu, c.guid, c.fmu);
end
end


function file = locate_fmu(name, here)
% The FMU file a block's FMUName names: as given (an absolute path), with .fmu added, in the
% current folder, beside this script, or on the MATLAB path (where the FMU block looks for it).
candidates = {name};
[~, ~, ext] = fileparts(name);
if ~strcmpi(ext, '.fmu')
    candidates{end + 1} = [name '.fmu'];
end
file = first_file(candidates, [{pwd, here}, strsplit(path, pathsep)]);
end


function file = first_file(names, folders)
% The first of names that is a file: an absolute name as it is, a relative one in the first
% of folders that has it (absolute paths only: Octave's fopen would search its load path).
file = '';
for i = 1:numel(names)
    if is_absolute(names{i})
        candidates = names(i);
    else
        candidates = cellfun(@(f) fullfile(f, names{i}), folders, 'UniformOutput', false);
    end
    for j = 1:numel(candidates)
        fid = fopen(candidates{j}, 'r');
        if fid >= 0
            fclose(fid);
            file = candidates{j};
            return
        end
    end
end
end


function absolute = is_absolute(name)
absolute = ~isempty(name) && (name(1) == '/' || name(1) == '\' || (numel(name) > 1 && name(2) == ':'));
end


function [guid, why] = fmu_guid(file)
% The guid attribute of the FMU's modelDescription.xml (FMI 3: instantiationToken).
guid = '';
why = '';
folder = tempname;
try
    unzip(file, folder);
    description = fullfile(folder, 'modelDescription.xml');
    if ~exist(description, 'file')
        why = 'no modelDescription.xml in it';
    else
        token = regexp(fileread(description), '\s(?:guid|instantiationToken)\s*=\s*"([^"]*)"', 'tokens', 'once');
        if isempty(token)
            why = 'modelDescription.xml has no guid';
        else
            guid = token{1};
        end
    end
catch err
    why = err.message;
end
if exist(folder, 'dir')
    if exist('OCTAVE_VERSION', 'builtin')
        confirm_recursive_rmdir(false, 'local');
    end
    rmdir(folder, 's');
end
end


function [pairs, problem] = block_settings(blk, c)
% The set_param arguments (name, text, ...) for the values of c on blk, or why there are none.
pairs = {};
problem = '';
dialog = get_param(blk, 'DialogParameters');
missing = {};
tops = {};
structs = {};
for i = 1:numel(c.names)
    name = c.names{i};
    parts = strsplit(name, '.');
    if isvarname(name) && isfield(dialog, name)
        pairs(end + 1:end + 2) = {name, c.text{i}};
    elseif numel(parts) > 1 && all(cellfun(@isvarname, parts)) && isfield(dialog, parts{1})
        % A structured name: a field of the struct the block parameter parts{1} evaluates to.
        t = find(strcmp(tops, parts{1}), 1);
        if isempty(t)
            tops{end + 1} = parts{1}; %#ok<AGROW>
            try
                structs{end + 1} = evalin('base', get_param(blk, parts{1})); %#ok<AGROW>
            catch err
                problem = sprintf('cannot evaluate its parameter %s (%s)', parts{1}, err.message);
                return
            end
            t = numel(tops);
        end
        structs{t} = setfield(structs{t}, parts{2:end}, c.values(i));
    else
        missing{end + 1} = name; %#ok<AGROW>
    end
end
if ~isempty(missing)
    problem = sprintf('the block has no parameter %s (its parameters: %s)%s', strjoin(missing, ', '), ...
                      strjoin(fieldnames(dialog)', ', '), mapping_hint(blk));
    pairs = {};
    return
end
for t = 1:numel(tops)
    pairs(end + 1:end + 2) = {tops{t}, struct_text(structs{t})};
end
end


function hint = mapping_hint(blk)
hint = '';
try
    hint = sprintf('; its FMUParamMapping is ''%s''', get_param(blk, 'FMUParamMapping'));
catch
end
end


function text = struct_text(s)
% MATLAB text that evaluates to struct s (numbers with 17 significant digits).
names = fieldnames(s);
parts = cell(1, numel(names));
for i = 1:numel(names)
    v = s.(names{i});
    if isstruct(v)
        value = struct_text(v);
    elseif ischar(v)
        value = ['''' strrep(v, '''', '''''') ''''];
    elseif islogical(v) && isscalar(v)
        value = mat2str(v);
    elseif isnumeric(v) && isscalar(v)
        value = sprintf('%.17g', v);
    else
        value = mat2str(v, 17);
    end
    parts{i} = sprintf('''%s'',%s', names{i}, value);
end
text = ['struct(' strjoin(parts, ',') ')'];
end


function [exported, source] = values_from_mat(matfile, here)
% The components of a .mat file written by pendfmu export (variable pendfmu_export).
file = first_file({matfile}, {pwd, here});
if isempty(file)
    error('pendfmu:set_parameters', 'set_parameters: no file %s (in the current folder or beside this script)', matfile);
end
loaded = load(file, 'pendfmu_export');
if ~isfield(loaded, 'pendfmu_export')
    error('pendfmu:set_parameters', 'set_parameters: %s has no variable pendfmu_export (not written by pendfmu export)', file);
end
meta = loaded.pendfmu_export;
source = meta.source;
exported = cell(1, numel(meta.blocks));
for k = 1:numel(meta.blocks)
    b = meta.blocks{k};
    c = struct('component', b.component, 'fmu', b.fmu, 'guid', b.guid);
    c.names = cellstr(b.names);
    c.values = b.values(:);
    c.units = cellstr(b.units);
    c.origins = cellstr(b.origins);
    types = cellstr(b.types);
    c.text = cell(numel(c.values), 1);
    for i = 1:numel(c.values)
        c.text{i} = value_text(c.values(i), types{i});
    end
    exported{k} = c;
end
end


function text = value_text(value, type)
% The block parameter text of a value: a Boolean parameter is a check box ('on'/'off').
switch type
    case 'Boolean'
        if value ~= 0, text = 'on'; else, text = 'off'; end
    case 'Integer'
        text = sprintf('%d', round(value));
    otherwise
        text = sprintf('%.17g', value);
end
end


function text = unit_text(unit)
if isempty(unit), text = ''; else, text = [' [' unit ']']; end
end


function hint = usage_hint(exported)
names = cellfun(@(c) c.component, exported, 'UniformOutput', false);
hint = sprintf('set_parameters(''%s'', PATH, ...)', strjoin(names, ''', PATH, '''));
end


function exported = table_to_components(components)
% Each component's table (name, value text, unit, type, origin) as the lists the code uses.
exported = components;
for k = 1:numel(components)
    c = components{k};
    t = c.parameters;
    c.names = t(:, 1);
    c.text = t(:, 2);
    c.values = str2double(t(:, 2));
    c.values(strcmp(t(:, 2), 'on')) = 1;
    c.values(strcmp(t(:, 2), 'off')) = 0;
    c.units = t(:, 3);
    c.origins = t(:, 5);
    exported{k} = rmfield(c, 'parameters');
end
end


% ---- Written by pendfmu export: the exported values ----------------------------------------

@DATA@
